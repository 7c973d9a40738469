"""Agreement of an estimated occupancy grid with a true occupancy raster on the same lattice.

``occupancy_agreement(grid, true_occupied)``: with E the estimated occupied cells
(``p > occupied_threshold``) and T the true ones,

    IoU       = |E ∩ T| / |E ∪ T|                          (exact cells)
    precision = |{e ∈ E : d(e, T) ≤ tol}| / |E|            (estimated walls near a true wall)
    recall    = |{t ∈ T : d(t, E) ≤ tol}| / |T|            (true walls found), restricted to
                true cells the map observed (known, i.e. ``|l − l0| > 0``, within ``tol``)

``tol`` is in cells (Chebyshev distance), so a wall drawn one cell off still counts at
``tol = 1``; ``tol = 0`` reduces precision/recall to exact matches.

``true_occupancy_on(grid, world, truth_in_map)`` rasterises a simulated world's walls onto the
grid's lattice after moving them by the SE(2) pose ``truth_in_map`` (the ground-truth frame
seen from the map frame, e.g. the inverse of the trajectory alignment): a SLAM map is only
defined up to its starting frame, and a one-cell offset of the whole map would otherwise
count as a wrong map.

Without ground truth (real logs such as fr-clinic) three self-consistency numbers:

``map_sharpness(grid)``: over the observed cells (``|l − l0| > 0``) the fraction decided
(free or occupied) and the mean ``|2p − 1|`` (0 for an undecided map, 1 for a binary one);
blurred walls and pose jitter leave cells undecided.

``hits_on_occupied(grid, scans, poses, index)``: the fraction of the usable end points of scans
``index`` (placed at ``poses``) that fall within ``tol`` cells of an occupied cell of the final map.

``wall_orientation_concentration(grid)``: for a rectilinear building, how well the map's walls
share two perpendicular directions: with the occupancy evidence ``m = max(2p − 1, 0)``, its
gradient (derivative of a Gaussian, σ = 2 cells) of magnitude ``w`` and direction ``θ`` per cell, ``R = |Σ w e^{4iθ}| / Σ w`` (1 when all
walls lie along two perpendicular directions, whatever the map's rotation; two equal walls 22.5°
apart give cos 45° = 0.71). Heading drift bends corridors and lowers R; it is blind to
translation. Numbers compare maps of the same building, not buildings.

The three are the experiment metric ``occupancy`` (:mod:`slamarena.experiments.metrics.occupancy`), on the map a
cell's trajectory implies.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "occupancy_agreement",
    "true_occupancy_on",
    "map_sharpness",
    "hits_on_occupied",
    "wall_orientation_concentration",
]


def _dilate(mask: np.ndarray, tol: int) -> np.ndarray:
    if tol <= 0:
        return mask
    from scipy.ndimage import binary_dilation

    return binary_dilation(mask, structure=np.ones((2 * tol + 1, 2 * tol + 1), bool))


def occupancy_agreement(grid, true_occupied: np.ndarray, tol: int = 1) -> dict:
    """IoU, precision and recall (see the module docstring); ``true_occupied`` on ``grid``'s lattice."""
    true_occupied = np.asarray(true_occupied, dtype=bool)
    if true_occupied.shape != grid.shape:
        raise ValueError(f"true occupancy {true_occupied.shape} is not on the grid's lattice {grid.shape}")
    est = grid.probability() > grid.params.cells.occupied_threshold
    known = _dilate(np.abs(grid.log_odds - grid.l0) > 1e-6, tol)
    union = (est | true_occupied).sum()
    seen_truth = true_occupied & known
    return {
        "iou": float((est & true_occupied).sum() / union) if union else float("nan"),
        "precision": float((est & _dilate(true_occupied, tol)).sum() / est.sum()) if est.any() else float("nan"),
        "recall": float((seen_truth & _dilate(est, tol)).sum() / seen_truth.sum())
        if seen_truth.any()
        else float("nan"),
        "occupied_cells": int(est.sum()),
        "true_cells_observed": int(seen_truth.sum()),
        "tol_cells": int(tol),
    }


def true_occupancy_on(grid, world="loop", truth_in_map=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Boolean occupancy (rows = y) of the ``sim:laser`` world moved into the map frame, on ``grid``'s lattice."""
    from slamarena.datasets.geometry import transform_points
    from slamarena.datasets.sim import laser

    w = laser._world(world)
    seg = laser.segments(w).reshape(-1, 2, 2)
    moved = transform_points(np.asarray(truth_in_map, dtype=float), seg)
    walls = tuple((tuple(a), tuple(b)) for a, b in moved.tolist())
    moved_world = laser.World(
        name=f"{w.name} (moved)", walls=walls, route=w.route, corner_radius=w.corner_radius, description=w.description
    )
    occupied, _ = laser.true_occupancy(grid.params.resolution, moved_world, origin=grid.origin, shape=grid.shape)
    return occupied


def map_sharpness(grid) -> dict:
    """Observed, occupied and free cells, the decided fraction and mean ``|2p − 1|`` of the observed cells."""
    p = grid.probability()
    known = np.abs(grid.log_odds - grid.l0) > 1e-6
    occupied, free = p > grid.params.cells.occupied_threshold, p < grid.params.cells.free_threshold
    n = int(known.sum())
    return {
        "known_cells": n,
        "occupied_cells": int(occupied.sum()),
        "free_cells": int(free.sum()),
        "decided_fraction": float((occupied | free).sum() / n) if n else float("nan"),
        "sharpness": float(np.mean(np.abs(2.0 * p[known] - 1.0))) if n else float("nan"),
    }


def _end_points(scans, pose, k, max_range):
    from slamarena.datasets.geometry import compose, transform_points

    r, a = scans.beams(k)
    ok = np.isfinite(r) & (r > 0) & (r < max_range)
    return ok, transform_points(
        compose(np.asarray(pose, dtype=float), scans.mount), np.column_stack([r * np.cos(a), r * np.sin(a)])
    )


def hits_on_occupied(grid, scans, poses, index, tol: int = 1) -> float:
    """Fraction of the usable end points of scans ``index`` at ``poses`` (one per index) within ``tol`` cells of an occupied cell."""
    near = _dilate(grid.probability() > grid.params.cells.occupied_threshold, tol)
    hits = total = 0
    for k, pose in zip(index, poses):
        ok, pts = _end_points(scans, pose, k, scans.max_range)
        ij = grid.world_to_grid(pts[ok])
        inside = grid.contains(ij)
        hits += int(near[ij[inside, 1], ij[inside, 0]].sum())
        total += int(ok.sum())
    return hits / total if total else float("nan")


def wall_orientation_concentration(grid, sigma: float = 2.0) -> float:
    """``R = |Σ w e^{4iθ}| / Σ w`` over the gradient of ``max(2p − 1, 0)`` (see the module docstring);
    derivative-of-Gaussian gradient with ``sigma`` cells (thin digital walls off the lattice axes
    would otherwise bias the directions towards them)."""
    from scipy.ndimage import gaussian_filter

    rows, cols = grid._known_box()
    m = np.clip(2.0 * grid.probability()[rows, cols] - 1.0, 0.0, None).astype(np.float32)
    gx, gy = gaussian_filter(m, sigma, order=(0, 1)), gaussian_filter(m, sigma, order=(1, 0))
    w = np.hypot(gx, gy).astype(np.float64)
    total = w.sum()
    return float(abs(np.sum(w * np.exp(4j * np.arctan2(gy, gx)))) / total) if total > 0 else float("nan")
