"""Map-quality numbers for logs without ground truth (slamarena.mapping.evaluation): hand-checked on a
four-cell grid, and on the hand-made room against known pose errors."""

from __future__ import annotations

import numpy as np
from conftest import make_sequence

from slamarena.mapping.evaluation import hits_on_occupied, map_sharpness, wall_orientation_concentration
from slamarena.mapping.occupancy_grid import OccupancyGrid, logit


def test_map_sharpness_by_hand():
    g = OccupancyGrid(resolution=0.1, width=10, height=10)
    g.log_odds[0, :4] = logit([0.9, 0.9, 0.1, 0.55])  # occupied, occupied, free, observed but undecided
    s = map_sharpness(g)
    assert s["known_cells"] == 4 and s["occupied_cells"] == 2 and s["free_cells"] == 1
    assert np.isclose(s["decided_fraction"], 0.75) and np.isclose(
        s["sharpness"], (0.8 + 0.8 + 0.8 + 0.1) / 4, atol=1e-6
    )


def _line(g, start, angle, length):
    s = np.linspace(0.0, length, int(length / (0.25 * g.params.resolution)))
    xy = np.asarray(start) + s[:, None] * [np.cos(angle), np.sin(angle)]
    ij = g.world_to_grid(xy)
    g.log_odds[ij[:, 1], ij[:, 0]] = logit(0.9)


def test_wall_orientation_concentration_by_hand():
    g = OccupancyGrid(resolution=0.05, width=600, height=600)
    _line(g, (-8.0, -6.0), 0.0, 12.0)
    _line(g, (-6.0, -7.0), np.pi / 2, 12.0)
    assert wall_orientation_concentration(g) > 0.93  # two perpendicular walls
    tilted = OccupancyGrid(resolution=0.05, width=600, height=600)
    _line(tilted, (-8.0, -6.0), np.radians(30.0), 12.0)
    _line(tilted, (-6.0, 2.0), np.radians(120.0), 12.0)
    assert wall_orientation_concentration(tilted) > 0.87  # the same, rotated (digital lines off the axes)
    bent = OccupancyGrid(resolution=0.05, width=600, height=600)
    _line(bent, (-8.0, -6.0), 0.0, 12.0)
    _line(bent, (-8.0, 4.0), np.radians(22.5), 12.0)  # second wall 22.5° off: R = |1 + e^{iπ/2}| / 2
    assert abs(wall_orientation_concentration(bent) - np.cos(np.pi / 4)) < 0.06


def test_wall_orientation_concentration_drops_with_heading_drift():
    seq = make_sequence(n=60, sigma=0.0)
    scans, truth = seq.scans, seq.ground_truth.poses
    drift = np.column_stack([np.zeros((len(truth), 2)), np.linspace(0.0, np.radians(15.0), len(truth))])
    R = []
    for poses in (truth, truth + drift):
        g = OccupancyGrid(resolution=0.05)
        for k in range(len(scans)):
            g.integrate(*scans.beams(k), poses[k], scans.mount, max_range=scans.max_range)
        R.append(wall_orientation_concentration(g))
    assert R[0] > 0.75 and R[1] < R[0] - 0.1, R


def test_hits_on_occupied_drop_when_the_poses_are_wrong():
    seq = make_sequence(n=60, sigma=0.0)
    scans, truth = seq.scans, seq.ground_truth.poses
    g = OccupancyGrid(resolution=0.05)
    for k in range(len(scans)):
        g.integrate(*scans.beams(k), truth[k], scans.mount, max_range=scans.max_range)
    index = np.arange(len(scans))
    assert hits_on_occupied(g, scans, truth, index) > 0.95
    assert hits_on_occupied(g, scans, truth + [0.3, -0.3, 0.0], index) < 0.5
