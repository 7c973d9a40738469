"""A finished map pyramid stored by its observed tiles: unpacked, it is the pyramid it was, cell for cell."""

from __future__ import annotations

import numpy as np

from slamarena.mapping.map_pyramid import MapPyramid, PackedPyramid
from slamarena.mapping.scan_matching.gauss_newton import GaussNewtonMatcher


def _pyramid() -> tuple[MapPyramid, np.ndarray]:
    """A pyramid of 30 scans of a 4 m room with one 60 m corridor (long beams grow the grids far beyond the room)."""
    rng = np.random.default_rng(0)
    maps = MapPyramid(size=10.0, centre=(0.0, 0.0))
    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    ranges = np.where(np.abs(angles) < 0.02, 60.0, 2.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles))))
    for k in range(30):
        pose = np.array([0.1 * k / 30, 0.0, 0.01 * k])
        maps.integrate(ranges + rng.normal(0.0, 0.01, ranges.size), angles, pose, max_range=80.0)
    return maps, np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])[np.abs(angles) > 0.05]


def test_unpacked_is_the_pyramid_cell_for_cell():
    maps, points = _pyramid()
    packed = PackedPyramid(maps)
    again = packed.unpack()
    assert again.version == maps.version and len(again.levels) == len(maps.levels)
    for a, b in zip(maps.levels, again.levels):
        assert a.shape == b.shape and np.array_equal(a.origin, b.origin) and a.log_odds.dtype == b.log_odds.dtype
        assert np.array_equal(a.log_odds, b.log_odds) and b.log_odds.flags.c_contiguous
        assert (a.version, a.cell_updates) == (b.version, b.cell_updates)
    dense = sum(g.log_odds.nbytes for g in maps.levels)
    assert packed.nbytes() < 0.5 * dense  # the corridor's beam grew the grids, its cells are mostly unobserved
    guess = np.array([0.05, -0.03, 0.02])
    one, two = GaussNewtonMatcher().match(maps, points, guess), GaussNewtonMatcher().match(again, points, guess)
    assert np.array_equal(one.pose, two.pose) and one.score == two.score


def test_an_unobserved_pyramid_packs_to_nothing():
    maps = MapPyramid(size=7.3)
    packed = PackedPyramid(maps, tile=8)
    assert packed.nbytes() < 100  # three empty compressed streams
    assert all(np.array_equal(a.log_odds, b.log_odds) for a, b in zip(maps.levels, packed.unpack().levels))


def test_laser_slam_keeps_finished_submaps_packed_and_the_same_estimate():
    """Finished submaps are held packed, at most loop.cache_submaps of them also dense; the estimate is the one a run
    that keeps every submap dense gives (a cache that never releases)."""
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = simulate(laps=2, k_r=0.1, k_rt=0.03, n_beams=181, seed=3)
    params = dict(frontend={"max_usable_range": 6.0}, loop={"search_every": 2}, tracking="submap", submap_scans=15)
    slam = LaserSLAM(**{**params, "loop": {**params["loop"], "cache_submaps": 2}})
    est = slam.run(seq)
    finished = [s for s in slam.submaps if s.finished]
    assert len(finished) > 4 and all(s.packed is not None for s in finished)
    assert sum(s._maps is not None for s in finished) <= 2 and est.meta["loop_candidates"] > 0
    dense = LaserSLAM(**{**params, "loop": {**params["loop"], "cache_submaps": 1000}}).run(seq)
    assert np.array_equal(est.poses, dense.poses)


def test_after_a_run_every_submap_is_held_packed_at_a_fraction_of_its_dense_form():
    """At the end of a run (the final solve, the refinement and the map need no grid of the mapping loop) every submap,
    the last active ones included, is held packed only and the loop search's cached grids are freed; the packed
    storage is a fraction of the dense pyramids it unpacks to, and the rendered map keeps no tracing scratch."""
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = simulate(laps=1, n_beams=181, seed=3)
    slam = LaserSLAM(frontend={"max_usable_range": 6.0}, tracking="submap", submap_scans=15)
    slam.run(seq)
    assert len(slam.submaps) > 4
    assert all(s.finished and s._maps is None for s in slam.submaps)
    packed = sum(s.packed.nbytes() for s in slam.submaps)
    dense = sum(g.log_odds.nbytes for s in slam.submaps for g in s.packed.unpack().levels)
    assert packed < 0.2 * dense, (packed, dense)
    assert getattr(slam.map, "_scratch_cells", None) is None
