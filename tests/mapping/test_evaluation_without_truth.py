"""Map-quality numbers for logs without ground truth (mapping.evaluation): hand-checked on a
four-cell grid, and on the hand-made room against known pose errors."""
from __future__ import annotations

import numpy as np
from conftest import make_sequence

from mapping.evaluation import hits_on_occupied, map_sharpness, wall_direction_spread
from mapping.occupancy_grid import OccupancyGrid, logit


def test_map_sharpness_by_hand():
    g = OccupancyGrid(resolution=0.1, width=10, height=10)
    g.log_odds[0, :4] = logit([0.9, 0.9, 0.1, 0.55])  # occupied, occupied, free, observed but undecided
    s = map_sharpness(g)
    assert s["known_cells"] == 4 and s["occupied_cells"] == 2 and s["free_cells"] == 1
    assert np.isclose(s["decided_fraction"], 0.75) and np.isclose(s["sharpness"], (0.8 + 0.8 + 0.8 + 0.1) / 4, atol=1e-6)


def test_wall_direction_spread_grows_with_heading_drift():
    seq = make_sequence(n=60, sigma=0.0)
    scans, truth = seq.scans, seq.ground_truth.poses
    index = np.arange(len(scans))
    exact, phi = wall_direction_spread(scans, truth, index)
    assert np.isfinite(phi).all() and exact < np.radians(0.5)  # the room's walls are axis-aligned (but one pillar)
    drift = np.linspace(0.0, np.radians(10.0), len(scans))  # heading error growing to 10°
    drifted, _ = wall_direction_spread(scans, truth + np.column_stack([0 * drift, 0 * drift, drift]), index)
    assert abs(drifted - np.std(drift)) < np.radians(0.5), (np.degrees(drifted), np.degrees(np.std(drift)))


def test_hits_on_occupied_drop_when_the_poses_are_wrong():
    seq = make_sequence(n=60, sigma=0.0)
    scans, truth = seq.scans, seq.ground_truth.poses
    g = OccupancyGrid(resolution=0.05)
    for k in range(len(scans)):
        g.integrate(*scans.beams(k), truth[k], scans.mount, max_range=scans.max_range)
    index = np.arange(len(scans))
    assert hits_on_occupied(g, scans, truth, index) > 0.95
    assert hits_on_occupied(g, scans, truth + [0.3, -0.3, 0.0], index) < 0.5
