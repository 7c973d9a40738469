"""Interlaced scans (per-scan ``angle_offset`` and ``beam_count``) in the grid and in GridSLAM.

A scan with offset δ must put its beams where a scan of the same readings at angles ``α + δ``
puts them, and a GridSLAM run over an interlaced stream (fr-clinic's four layouts: 181 beams
from −90°, 180 beams from −89.75°, −89.5°, −89.25°) must be as good as over a uniform one. The
negative controls drop the offsets: hits leave the walls, and the matched heading of each layout
jumps by its offset.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from conftest import WALLS, interlace, make_sequence, raycast

from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sequence import Scans
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.occupancy_grid import OccupancyGrid


def _distance_to_walls(xy: np.ndarray) -> np.ndarray:
    a, d = WALLS[:, :2], WALLS[:, 2:] - WALLS[:, :2]
    u = np.clip(((xy[:, None, :] - a) * d).sum(-1) / (d * d).sum(-1), 0.0, 1.0)
    return np.linalg.norm(xy[:, None, :] - (a + u[..., None] * d), axis=-1).min(axis=1)


def _hit_cells(grid: OccupancyGrid) -> np.ndarray:
    return grid.grid_to_world(np.argwhere(grid.log_odds > grid.l0)[:, ::-1])


def test_a_scan_with_an_offset_lands_on_the_walls_it_saw():
    pose = np.array([-4.0, -3.0, 0.3])
    angles = np.radians(np.linspace(-90.0, 90.0, 37))  # 5° steps
    delta, n = np.radians(2.5), 36  # half a step later, one beam fewer
    r = raycast(pose, angles[:n] + delta)
    ranges = np.zeros((1, 37))
    ranges[0, :n] = r
    offset_scan = Scans(t=[0.0], ranges=ranges, angles=angles, max_range=20.0, angle_offset=[delta], beam_count=[n])
    shifted_layout = Scans(t=[0.0], ranges=r[None], angles=angles[:n] + delta, max_range=20.0)
    grids = []
    for scans in (offset_scan, shifted_layout):
        grid = OccupancyGrid(resolution=0.05)
        grid.integrate(*scans.beams(0), pose, max_range=20.0)
        grids.append(grid)
    assert np.array_equal(grids[0].origin, grids[1].origin) and np.array_equal(grids[0].log_odds, grids[1].log_odds)
    hits = _hit_cells(grids[0])
    assert len(hits) == n and np.all(
        _distance_to_walls(hits) <= 0.5 * 0.05 * np.sqrt(2) + 1e-9
    )  # every hit cell on a wall
    ignored = OccupancyGrid(resolution=0.05)
    ignored.integrate(r, angles[:n], pose, max_range=20.0)  # the same readings at the unshifted angles
    assert np.mean(_distance_to_walls(_hit_cells(ignored)) > 0.05) > 0.5


def test_grid_slam_honours_per_scan_offsets():
    seq = make_sequence()  # 181 beams over 180°, 1° steps
    scans = interlace(seq)
    q = np.arange(len(scans)) % 4
    step = scans.angles[1] - scans.angles[0]
    runs = {}
    for label, sc in (("honoured", scans), ("ignored", dataclasses.replace(scans, angle_offset=None))):
        est = GridSLAM().run(dataclasses.replace(seq, scans=sc))
        heading = wrap_angle(est.poses[:, 2] - seq.ground_truth.poses[:, 2])
        runs[label] = (est, heading, np.array([heading[q == j].mean() - heading[q == 0].mean() for j in range(4)]))
    est, heading, jumps = runs["honoured"]
    assert est.meta["bad_beams"] == 0 and est.meta["scans_all_no_return"] == 0  # padding is no beam, not a bad one
    assert np.array_equal(est.diagnostics["usable_beams"] + est.diagnostics["no_return_beams"], scans.beam_count)
    assert np.sqrt(np.mean(heading**2)) < 0.004 and np.abs(jumps).max() < 0.1 * step
    assert np.sqrt(np.mean(np.sum((est.poses[:, :2] - seq.ground_truth.poses[:, :2]) ** 2, axis=1))) < 0.03
    _, heading, jumps = runs["ignored"]  # each layout's heading jumps by its offset
    assert np.allclose(jumps, np.arange(4) * step / 4, atol=0.25 * step / 4)
    assert np.sqrt(np.mean(heading**2)) > 2 * np.sqrt(np.mean(runs["honoured"][1] ** 2))
