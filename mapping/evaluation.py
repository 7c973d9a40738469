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
"""
from __future__ import annotations

import numpy as np

__all__ = ["occupancy_agreement", "true_occupancy_on"]


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
    est = grid.probability() > grid.occupied_threshold
    known = _dilate(np.abs(grid.log_odds - grid.l0) > 1e-6, tol)
    union = (est | true_occupied).sum()
    seen_truth = true_occupied & known
    return {
        "iou": float((est & true_occupied).sum() / union) if union else float("nan"),
        "precision": float((est & _dilate(true_occupied, tol)).sum() / est.sum()) if est.any() else float("nan"),
        "recall": float((seen_truth & _dilate(est, tol)).sum() / seen_truth.sum()) if seen_truth.any() else float("nan"),
        "occupied_cells": int(est.sum()),
        "true_cells_observed": int(seen_truth.sum()),
        "tol_cells": int(tol),
    }


def true_occupancy_on(grid, world="loop", truth_in_map=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Boolean occupancy (rows = y) of the ``sim:laser`` world moved into the map frame, on ``grid``'s lattice."""
    from datasets.geometry import transform_points
    from datasets.sim import laser

    w = laser._world(world)
    seg = laser.segments(w).reshape(-1, 2, 2)
    moved = transform_points(np.asarray(truth_in_map, dtype=float), seg)
    walls = tuple((tuple(a), tuple(b)) for a, b in moved.tolist())
    moved_world = laser.World(name=f"{w.name} (moved)", walls=walls, route=w.route, corner_radius=w.corner_radius, description=w.description)
    occupied, _ = laser.true_occupancy(grid.resolution, moved_world, origin=grid.origin, shape=grid.shape)
    return occupied
