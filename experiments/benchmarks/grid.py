"""``slamarena bench grid``: occupancy-grid update throughput and memory.

1. Cell updates per second of the vectorised scan integration
   (:meth:`slamarena.mapping.occupancy_grid.OccupancyGrid.integrate`: Bresenham over all beams at once,
   deduplication, one log-odds update per cell) against :func:`integrate_literal`, the
   per-beam, per-cell Python loop of the textbook, on the same scans in the same run: the
   ratio, and a check that both produce the same grid.
2. Scaling: time per scan against cells traced per scan (range cap 2–16 m), fitted log-log
   exponent (≈ 1: the cost is linear in the cells a scan touches).
3. Memory of a 2000 × 2000 grid: the float32 log-odds array, the int8 ROS export, and the
   notes' "about 36 MB", which is 9 bytes per cell: float64 log-odds plus an int8 grid.

Scans: the SLAM-corrected Intel log (known poses) when staged, else ``sim:laser``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from slamarena.datasets.geometry import compose, transform_points
from slamarena.experiments.benchmarks import loglog_slope, table, write_rows
from slamarena.mapping.occupancy_grid import OccupancyGrid
from slamarena.mapping.raytrace import bresenham

#: the corrected Intel log when staged, else sim:laser
STAGED_DATA: dict[str, bool] = {"carmen-corrected:intel": False}


def integrate_literal(
    grid: OccupancyGrid, ranges, angles, pose, mount=(0.0, 0.0, 0.0), max_range=np.inf, clear_range=None
) -> int:
    """The textbook loop: per beam, per traced cell, with the same model as ``integrate``.

    Same semantics (one update per cell per scan, hit wins, no-return clears to
    ``clear_range``), written as loops over beams and cells; the reference for the benchmark
    ratio and the equality test. The grid must already contain the scan (no growing).
    """
    sensor = compose(np.asarray(pose, float), np.asarray(mount, float))
    c0 = grid.world_to_grid(sensor[:2])
    free: set[int] = set()
    hits: set[int] = set()
    h, w = grid.shape
    for r, a in zip(ranges, angles):
        if not np.isfinite(r) or r <= 0:
            continue
        hit = r < max_range
        reach = r if hit else min(r, max_range if clear_range is None else clear_range)
        end = transform_points(sensor, np.array([reach * np.cos(a), reach * np.sin(a)]))
        c1 = grid.world_to_grid(end)
        xs, ys, _, steps = bresenham(c0[0], c0[1], c1[0], c1[1])
        for x, y, s in zip(xs.tolist(), ys.tolist(), steps.tolist()):
            if 0 <= x < w and 0 <= y < h:
                (hits if hit and s == steps[-1] else free).add(y * w + x)
    flat = grid.log_odds.reshape(-1)
    for idx in free - hits:
        flat[idx] = min(max(flat[idx] + grid.l_miss - grid.l0, grid.l_min), grid.l_max)
    for idx in hits:
        flat[idx] = min(max(flat[idx] + grid.l_hit - grid.l0, grid.l_min), grid.l_max)
    grid.version += 1
    return len(free - hits) + len(hits)


def _scans():
    from slamarena import datasets
    from slamarena.datasets.errors import DatasetNotFoundError

    try:
        seq = datasets.load("carmen-corrected:intel")
        return "carmen-corrected:intel", seq.scans
    except (DatasetNotFoundError, KeyError):
        seq = datasets.load("sim:laser")
        return "sim:laser (truth poses)", seq.scans


def _grid_for(scans, poses, cap):
    reach = min(scans.max_range, cap) + 1.0
    lo, hi = poses[:, :2].min(axis=0) - reach, poses[:, :2].max(axis=0) + reach
    n = np.ceil((hi - lo) / 0.05).astype(int)
    return OccupancyGrid(resolution=0.05, width=int(n[0]), height=int(n[1]), origin=tuple(lo), grow=False)


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    console = Console()
    name, scans = _scans()
    K = 60 if quick else 300
    idx = np.linspace(0, len(scans.t) - 1, K).astype(int)
    poses = scans.pose[idx]
    cap = 8.0

    # 1. vectorised vs literal on the same scans
    fast, slow = _grid_for(scans, poses, cap), _grid_for(scans, poses, cap)
    t = time.perf_counter()
    n_fast = sum(fast.integrate(*scans.beams(k), scans.pose[k], scans.mount, scans.max_range, cap) for k in idx)
    t_fast = time.perf_counter() - t
    sub = idx[: max(K // 10, 5)]
    t = time.perf_counter()
    for k in sub:
        integrate_literal(slow, *scans.beams(k), scans.pose[k], scans.mount, scans.max_range, cap)
    t_slow = time.perf_counter() - t
    check = _grid_for(scans, poses, cap)
    for k in sub:
        check.integrate(*scans.beams(k), scans.pose[k], scans.mount, scans.max_range, cap)
    same = bool(np.array_equal(check.log_odds, slow.log_odds))
    per_scan_fast, per_scan_slow = t_fast / len(idx), t_slow / len(sub)
    updates = table(
        f"grid updates on {name} ({len(idx)} scans, {scans.ranges.shape[1]} beams, 0.05 m, no-return cleared to {cap} m)",
        ("implementation", "ms / scan", "cell updates / s", "ratio"),
    )
    rate = n_fast / t_fast
    updates.add_row("vectorised (numpy)", f"{1e3 * per_scan_fast:.2f}", f"{rate:,.0f}", "1")
    updates.add_row(
        "literal loop",
        f"{1e3 * per_scan_slow:.2f}",
        f"{rate * per_scan_fast / per_scan_slow:,.0f}",
        f"{per_scan_slow / per_scan_fast:.1f}× slower",
    )
    console.print(updates)
    console.print(f"literal and vectorised grids identical on {len(sub)} scans: {same}")

    # 2. scaling with the cells a scan traces
    caps = [2.0, 4.0, 8.0, 16.0]
    cells, times = [], []
    for c in caps:
        g = _grid_for(scans, poses, c)
        t = time.perf_counter()
        n = 0
        for k in idx:
            r, a = scans.beams(k)
            n += g.integrate(
                np.minimum(r, c + 0.5) if c < scans.max_range else r,
                a,
                scans.pose[k],
                scans.mount,
                min(scans.max_range, c),
                c,
            )
        times.append((time.perf_counter() - t) / len(idx))
        cells.append(n / len(idx))
    slope = loglog_slope([{"cells": c, "time": t} for c, t in zip(cells, times)], "time", 0, np.inf, size="cells")
    console.print("cells per scan: " + ", ".join(f"{c:,.0f}" for c in cells) + f"; time per scan ∝ cells^{slope:.2f}")

    # 3. memory of a 2000 × 2000 grid
    big = OccupancyGrid(resolution=0.05, width=2000, height=2000, grow=False)
    ros = big.to_ros()
    notes = 2000 * 2000 * (8 + 1)
    console.print(
        f"2000 × 2000 grid: log-odds float32 {big.nbytes() / 1e6:.1f} MB + int8 ROS grid {ros.nbytes / 1e6:.1f} MB "
        f"= {(big.nbytes() + ros.nbytes) / 1e6:.1f} MB; the notes' ~36 MB = 9 B/cell (float64 log-odds + int8 grid: {notes / 1e6:.0f} MB); "
        f"ratio {notes / (big.nbytes() + ros.nbytes):.2f}"
    )
    summary = {
        "vectorised_ms_per_scan": 1e3 * per_scan_fast,
        "literal_ms_per_scan": 1e3 * per_scan_slow,
        "cell_updates_per_s": rate,
        "speedup": per_scan_slow / per_scan_fast,
        "identical": same,
        "scaling_exponent": slope,
        "grid_2000_MB": (big.nbytes() + ros.nbytes) / 1e6,
        "notes_MB": notes / 1e6,
    }
    write_rows([{"quantity": k, "value": v} for k, v in summary.items()], out, "grid.csv")
    return 0 if same else 1
