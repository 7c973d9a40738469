"""The covariance laser graph SLAM's front end hands its graph (research/method/laser_degeneracy.md, "Covariance"):
the odometry's covariance accumulated over an interval against composing with GTSAM's Jacobians, the information-form
fusion against its literal form, the NEES of the sequential factors against the simulated truth, and the loop
search's uniqueness test (pruned by the max-pyramid) against the exhaustive response."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest
from scipy.stats import chi2

from slamarena.datasets.sim.laser import simulate
from slamarena.mapping.laser_slam.interval import IntervalCovariance, OdometryNoiseParams, fuse


def test_interval_covariance_equals_composing_with_gtsams_jacobians():
    rng = np.random.default_rng(0)
    noise = OdometryNoiseParams()
    motions = np.column_stack([rng.uniform(0.0, 0.3, 12), rng.normal(0, 0.02, 12), rng.normal(0, 0.2, 12)])
    interval = IntervalCovariance(noise)
    T, Q = gtsam.Pose2(), np.zeros((3, 3))
    for u in motions:
        interval.step(u)
        H1, H2 = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
        T = T.compose(gtsam.Pose2(*u), H1, H2)
        Q = H1 @ Q @ H1.T + H2 @ noise.cov(u) @ H2.T
    np.testing.assert_allclose(interval.Q, Q, rtol=1e-10, atol=1e-15)
    interval.step(None)
    assert interval.Q is None
    interval.reset()
    np.testing.assert_array_equal(interval.Q, np.zeros((3, 3)))


def test_odometry_variance_adds_over_a_stretch_whatever_the_scan_rate():
    noise = OdometryNoiseParams(k_t=0.05, k_s=0.02, k_r=0.03, k_rt=0.01)
    coarse, fine = IntervalCovariance(noise), IntervalCovariance(noise)
    coarse.step(np.array([1.0, 0.0, 0.0]))
    for _ in range(10):
        fine.step(np.array([0.1, 0.0, 0.0]))
    np.testing.assert_allclose(np.diag(fine.Q)[[0, 2]], np.diag(coarse.Q)[[0, 2]], rtol=1e-12)
    assert fine.Q[1, 1] > coarse.Q[1, 1]  # across: the heading's noise along the way adds lever-arm variance


def test_fusion_is_the_information_sum_and_keeps_the_odometry_where_the_scan_has_nothing():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(3, 3))
    Q = A @ A.T + 0.1 * np.eye(3)
    B = rng.normal(size=(3, 3))
    information = B @ B.T
    np.testing.assert_allclose(fuse(Q, information), np.linalg.inv(np.linalg.inv(Q) + information), rtol=1e-9)
    u = np.array([np.cos(0.4), np.sin(0.4), 0.0])  # the scan has no information along u
    P = np.eye(3) - np.outer(u, u)
    S = fuse(Q, 1e12 * P @ np.diag([1.0, 2.0, 3.0]) @ P)
    np.testing.assert_allclose(u @ S @ u, 1.0 / (u @ np.linalg.inv(Q) @ u), rtol=1e-4)
    np.testing.assert_allclose(fuse(np.zeros((3, 3)), information), np.zeros((3, 3)))  # no motion, no uncertainty


def _sequential_nees(world: str, seed: int, **params):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[2] / "research" / "scripts"))
    from degeneracy_nees import sequential_nees

    from slamarena.mapping.laser_slam.slam import LaserSLAM

    seq = simulate(world=world, seed=seed)
    slam = LaserSLAM(**params)
    est = slam.run(seq)
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    return sequential_nees(est, slam.pose_graph, truth)


def test_sequential_factors_are_not_overconfident_on_the_corridor_world():
    """``sim:laser`` ``corridor`` (seed 1), shipped defaults: the NEES of the sequential factors against the truth.
    Their mean lies below χ²₃'s upper bound for that many factors (not overconfident), and along the motion — the
    direction the corridor leaves to the odometry — the factors' errors are at their stated size (1-dof NEES)."""
    nees, errors = _sequential_nees("corridor", 1)
    n = len(nees)
    assert n > 300
    typical = nees[nees < chi2.ppf(0.999, 3)]  # the map's rare slips (the end wall's frontier) are not noise
    assert len(typical) > 0.99 * n
    assert typical.mean() < chi2.ppf(0.975, 3 * len(typical)) / len(typical)
    assert typical.mean() > 0.1  # and not so conservative that the graph ignores them


@pytest.mark.parametrize("world", ["aliased_rooms", "corridor"])
def test_the_pruned_uniqueness_response_equals_the_exhaustive_one_above_its_threshold(world):
    """The loop search's uniqueness test (``LoopCloser._regions``) evaluates only the tiles of shifts whose
    max-pyramid bound reaches the threshold: above it the response is the exhaustive one, cell for cell, so the regions
    counted are the same (repeated rooms: several; a corridor: one)."""
    from types import SimpleNamespace

    from scipy.ndimage import label

    from slamarena.mapping.laser_slam.loop_closure import (
        _TILE_DEPTH,
        LoopCloser,
        LoopClosureParams,
        _best_over_angles,
        voxel_filter,
    )
    from slamarena.mapping.map_pyramid import MapPyramid, PyramidParams

    seq = simulate(world=world, seed=0, max_range=8.0)
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    maps = MapPyramid.around(PyramidParams(), truth[0], 30.0)
    for k in range(0, 300, 3):
        r, a = seq.scans.beams(k)
        maps.integrate(r, a, truth[k], seq.scans.mount, max_range=seq.scans.max_range)
    closer = LoopCloser(LoopClosureParams())
    submap = SimpleNamespace(index=0, maps=maps)
    cache = closer._precomputed(submap)
    closer.modes.active = cache
    counts = []
    for k in (40, 150, 260):
        r, a = seq.scans.beams(k)
        ok = np.isfinite(r) & (r < seq.scans.max_range)
        pts = voxel_filter(np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])]), 0.1)
        pose = truth[k] + np.array([0.05, -0.03, 0.01])
        m = closer.modes
        grid = maps.levels[closer.p.level]
        dth, na = m._angles(grid, pts)
        ix, iy = m._cells(grid, cache["pad"] - cache["corner"], pts, pose, pose[2] + np.arange(-na, na + 1) * dth)
        w = m._w(grid)
        S, _, _ = m._response(cache["pyramid"][0], ix, iy, range(2 * na + 1), w, w)
        exhaustive = S.max(axis=0)
        slack = closer.p.ambiguity * len(pts)
        pruned = _best_over_angles(cache["pyramid"], _TILE_DEPTH, ix, iy, w, slack)
        above = exhaustive >= exhaustive.max() - slack
        np.testing.assert_array_equal(pruned >= pruned.max() - slack, above)
        np.testing.assert_array_equal(pruned[above], exhaustive[above])
        assert np.isinf(pruned).mean() > 0.3  # most tiles were never evaluated
        counts.append(label(above, structure=np.ones((3, 3)))[1])
        assert closer._regions(submap, pts, pose, closer.p.linear_window) == counts[-1]
    assert max(counts) > 1 if world == "aliased_rooms" else max(counts) == 1


def test_search_windows_from_the_marginals_widen_with_drift_and_collapse_after_a_loop():
    """A straight corridor drive: nodes 0.4 m apart, each sequential factor the interval's odometry covariance fused
    with a corridor match (no information along it). The loop search's half-width for node n against node 0
    (shipped floors) grows with the distance driven and falls back once a loop joins n to 0."""
    from slamarena.mapping.laser_slam.backend import Backend
    from slamarena.mapping.laser_slam.consistency import OdometryChain
    from slamarena.mapping.laser_slam.loop_closure import LoopCloser, LoopClosureParams
    from slamarena.robust import RobustKernelParams

    params = LoopClosureParams()
    assert params.min_linear_window < params.linear_window  # the floors are below the caps: the windows act
    closer = LoopCloser(params)
    backend, chain = Backend(RobustKernelParams(robust="cauchy", robust_k=1.0)), OdometryChain()
    corridor = np.diag([0.0, 1e5, 1e6])  # across and heading constrained by the match, along not
    z = np.array([0.4, 0.0, 0.0])
    pose = np.zeros(3)
    backend.add_node(0, pose)
    chain.add(pose, None)
    widths = {}
    for i in range(1, 121):
        interval = IntervalCovariance(OdometryNoiseParams())
        for _ in range(4):
            interval.step(z / 4)
        cov = fuse(interval.Q, corridor) + np.diag([0.02**2, 0.02**2, 0.005**2])
        pose = pose + z
        backend.add_node(i, pose, z, cov)
        chain.add(pose, cov)
        if i in (10, 40, 120):
            widths[i] = closer.window(backend.relative_cov(0, i, chain))[0]
    assert widths[10] < widths[40] < widths[120] <= params.linear_window
    assert widths[10] <= 0.6 and widths[40] > params.min_linear_window
    backend.set_loops({"loop": (0, 120, np.array([48.0, 0.0, 0.0]), np.diag([0.05**2, 0.05**2, 0.01**2]))}, [])
    assert closer.window(backend.relative_cov(0, 120, chain))[0] < 0.5 * widths[120]
