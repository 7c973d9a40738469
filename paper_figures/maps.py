"""Maps: the laser scans placed at each method's poses, per dataset a laser mapping method ran on; before and after
loop closure where the method records both.

A results directory keeps every cell's trajectory (``estimate.npz``), not its grid. The map a trajectory implies is
re-drawn from the dataset's scans, which is cheap: the dataset is loaded once (its first seed), the end point of
every valid beam (finite, positive, short of the maximum range) of every ``stride``-th scan is placed at the
method's pose at the scan's stamp (SE(2) interpolation of the estimate, moved into the ground-truth frame by the
cell's ATE alignment so panels compare) — ``p = (x ⊕ mount) ⊕ (r cos α, r sin α)`` — and the hits are counted on
one grid for all panels (grey, log scale). A blurred or doubled wall is a pose error. The grid spans the
hits of every panel but the dead-reckoning ones: odometry drifts tens of metres on the classic logs, and framing it
too would shrink every map to a corner; its panel is clipped to the same view.

A dataset that cannot be loaded here (results copied from another machine) has no map figure; the reason is
reported.

Panels: the ground truth (where the dataset has one), then every method of the first seed. A method whose
estimate carries its poses before loop closure (``diagnostics["front_end_poses"]``, one per estimate stamp) gets
a second panel, "before loop closure", and its accepted loop closures (``loop_node``, ``loop_anchor``,
``loop_accepted`` with ``node_scan``: :mod:`slamarena.mapping.laser_slam`) are drawn on the panel after it as
segments between the two nodes they join.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .runs import FigureSkipped, by, load_runs
from .style import PAGE, TRUTH, MethodStyles, figure, panels_used, save

__all__ = ["plot", "end_points", "MAX_POINTS"]

MAX_POINTS = 300_000  # beam end points drawn per panel (scans thinned to a stride)
CELLS = 400  # grid cells across the larger side of the map


def end_points(scans, t: np.ndarray, poses: np.ndarray, stride: int) -> np.ndarray:
    """(n, 2) end points of the valid beams of every ``stride``-th scan inside the trajectory's span, placed at the
    trajectory (``t``, ``poses``) interpolated at the scan stamps."""
    from slamarena.datasets.geometry import compose, interpolate_poses, transform_points

    index = np.flatnonzero((scans.t >= t[0]) & (scans.t <= t[-1]))[::stride]
    if index.size == 0:
        return np.zeros((0, 2))
    at = compose(interpolate_poses(t, poses, scans.t[index]), scans.mount)
    out = []
    for pose, k in zip(at, index):
        r, a = scans.beams(k)
        ok = np.isfinite(r) & (r > 0) & (r < scans.max_range)
        out.append(transform_points(pose, np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])])))
    return np.vstack(out)


def _dataset(run):
    from slamarena import datasets

    spec = run.info["dataset"]
    params = dict(spec["params"], seed=run.seed) if spec.get("simulator") else dict(spec["params"])
    return datasets.load(spec["name"], **params)


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    from slamarena.mapping import REGISTRY as MAPPERS

    every = load_runs(results_dir)
    styles = MethodStyles.of(results_dir, every)
    mapped = {r.dataset for r in every if r.method in MAPPERS}
    if not mapped:
        raise FigureSkipped(f"no laser mapping method ({', '.join(MAPPERS)}) in the results")
    from slamarena.errors import UserError

    written, missing = [], []
    for (dataset,), group in by([r for r in every if r.dataset in mapped], "dataset").items():
        seed = min(r.seed for r in group)
        shown = [r for r in group if r.seed == seed]
        try:
            scans = _dataset(shown[0]).scans
        except UserError as exc:  # the dataset is not on this machine (results copied here), or unknown to this version
            missing.append(f"{dataset}: {exc}")
            continue
        if scans is None or len(scans) == 0:
            missing.append(f"{dataset}: no laser scans")
            continue
        stride = max(1, int(np.ceil(len(scans) * scans.ranges.shape[1] / MAX_POINTS)))
        panels = []  # (title, t, poses in the truth frame, style, loops)
        truth = next((r.truth for r in shown if "poses" in r.truth), None)
        if truth is not None:
            panels.append(("ground truth", truth["t"], truth["poses"], TRUTH, None))
        loops_drawn = 0
        for run in shown:
            est, A = run.estimate, run.alignment
            style = styles(run.estimator)
            d = est.diagnostics
            if "front_end_poses" in d:
                panels.append(
                    (f"{run.estimator}, before loop closure", est.t, A.poses(d["front_end_poses"]), style, None)
                )
            loops = None
            if {"loop_node", "loop_anchor", "loop_accepted", "node_scan"} <= set(d):
                nodes = A.poses(est.poses[d["node_scan"]])[:, :2]
                ok = d["loop_accepted"].astype(bool)
                loops = np.stack([nodes[d["loop_node"][ok]], nodes[d["loop_anchor"][ok]]], axis=1)
                loops_drawn += len(loops)
            panels.append(
                (
                    f"{run.estimator}" + (", after loop closure" if "front_end_poses" in d else ""),
                    est.t,
                    A.poses(est.poses),
                    style,
                    loops,
                )
            )
        points = [end_points(scans, t, poses, stride) for _, t, poses, _, _ in panels]
        # the extent of the maps that are maps: a baseline's drift (odometry) would shrink every other panel to a corner;
        # it is clipped to that extent instead
        baseline = {styles(r.estimator)["label"] for r in shown if r.method == "dead_reckoning"}
        framing = [p for p, (_, _, _, style, _) in zip(points, panels) if style.get("label") not in baseline] or points
        every_point = np.vstack(framing)
        lo, hi = np.percentile(every_point, 0.5, axis=0), np.percentile(every_point, 99.5, axis=0)
        size = float(np.max(hi - lo)) / CELLS
        edges = [np.arange(lo[k] - 5 * size, hi[k] + 6 * size, size) for k in (0, 1)]
        ncols = min(3, len(panels))
        nrows = -(-len(panels) // ncols)
        aspect = (edges[1][-1] - edges[1][0]) / (edges[0][-1] - edges[0][0])
        fig, axes = figure(
            PAGE,
            nrows * PAGE / ncols * min(max(aspect, 0.5), 1.5) + 0.5,
            nrows=nrows,
            ncols=ncols,
            sharex=True,
            sharey=True,
        )
        for ax, (title, t, poses, style, loops), pts in zip(axes.flat, panels, points):
            counts, _, _ = np.histogram2d(pts[:, 0], pts[:, 1], bins=edges)
            shade = (
                np.log1p(counts.T) / max(np.log1p(np.percentile(counts[counts > 0], 99)), 1e-9)
                if counts.any()
                else counts.T
            )
            ax.imshow(
                np.clip(shade, 0, 1),
                origin="lower",
                cmap="gray_r",
                extent=(edges[0][0], edges[0][-1], edges[1][0], edges[1][-1]),
                interpolation="nearest",
            )
            ax.plot(
                poses[:, 0],
                poses[:, 1],
                color=style["color"],
                linestyle=style.get("linestyle", "-"),
                linewidth=0.6,
                label=style["label"],
            )
            if loops is not None and len(loops):
                for a, b in loops:
                    ax.plot([a[0], b[0]], [a[1], b[1]], color="#CC3311", linewidth=0.5, label="accepted loop closure")
            ax.set_xlim(edges[0][0], edges[0][-1])
            ax.set_ylim(edges[1][0], edges[1][-1])
            ax.set_title(title)
            ax.set_aspect("equal")
            ax.grid(False)
        panels_used(axes, len(panels), "x [m]")
        for ax in axes[:, 0]:
            ax.set_ylabel("y [m]")
        caption = (
            f"{dataset}, seed {seed}: the laser scans' end points placed at each trajectory (moved into the ground-truth frame "
            f"by the cell's ATE alignment), {'every scan' if stride == 1 else f'one scan in {stride}'}, "
            f"hit counts per {size:.2g} m cell on a log "
            f"grey scale, the trajectory drawn over them"
            + (
                f"; {loops_drawn} accepted loop closures as red segments between the nodes they join"
                if loops_drawn
                else ""
            )
            + ". A blurred or doubled wall is a pose error. The view spans the maps of the "
            "SLAM methods; a dead-reckoning panel is clipped to it (its drift leaves the view)."
        )
        written += save(fig, out_dir, f"maps_{dataset}", caption)
    if not written:
        raise FigureSkipped("; ".join(missing))
    return written
