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


def test_the_matchers_information_is_its_covariance_without_the_prior_and_empty_along_a_corridor():
    """A room scan (not degenerate): ``info["information"]`` is the inverse of the Laplace covariance. A corridor scan
    with odometry (τ = 0.003): (almost) no information along the corridor, and with the prior's Λ added back it is the inverse
    of the reported covariance (up to σ̂² at the guess against at the match)."""
    from test_degeneracy import _map, _scan

    from slamarena.mapping.scan_matching.gauss_newton import GaussNewtonMatcher

    poses = np.array([[8.0, 6.5, 0.0], [10.0, 6.5, 0.05], [12.0, 6.4, -0.05], [14.0, 6.5, 0.0]])
    truth = np.array([11.0, 6.45, 0.02])
    room = GaussNewtonMatcher().match(_map("rooms", poses), _scan("rooms", truth)[0], truth + [0.03, -0.02, 0.01])
    np.testing.assert_allclose(room.info["information"], np.linalg.inv(room.cov), rtol=1e-6)
    maps = _map("corridor", [np.array([x, 2.0, 0.0]) for x in (36.0, 38.0, 40.0)])
    truth = np.array([40.3, 2.0, 0.0])
    pts = np.ascontiguousarray(_scan("corridor", truth)[0])
    res = GaussNewtonMatcher(degeneracy_threshold=0.003).match(maps, pts, truth + [0.08, 0.05, 0.02], odometry=True)
    info = res.info["information"]
    assert res.info["degenerate"] == 1
    assert info[0, 0] < 1e-3 * info[1, 1]  # along: nothing but u_0's tilt from the estimated normals
    lam = np.linalg.inv(res.cov) - info  # the prior's Λ = W/σ̂²: diagonal, equal translation weights
    np.testing.assert_allclose(lam, np.diag(np.diag(lam)), atol=1e-6 * lam[0, 0])
    assert lam[0, 0] == pytest.approx(lam[1, 1], rel=1e-6)


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


DEGENERATE = {"frontend": {"matcher_params": {"degeneracy_threshold": 0.003}}, "odometry_noise": {}}


def test_sequential_factors_are_not_overconfident_on_the_corridor_world():
    """``sim:laser`` ``corridor`` (seed 1), degeneracy on (τ = 0.003) with the interval covariance (``odometry_noise``
    at its defaults): the NEES of the sequential factors against the truth. Apart from the map's rare slips (beyond
    χ²₃'s 99.9 % quantile; measured 4 of 371, one a 1.2 m slip where the end wall comes into view), their mean lies
    below the upper bound of χ²'s 95 % interval for that many factors' dof (measured 0.33 against 2.75 … 3.26: the
    floors, 2 cm and 5 mrad, are conservative on a simulated map), and not near zero."""
    nees, _ = _sequential_nees("corridor", 1, **DEGENERATE)
    n = len(nees)
    assert n > 300
    typical = nees[nees < chi2.ppf(0.999, 3)]
    assert len(typical) >= 0.98 * n
    assert typical.mean() < chi2.ppf(0.975, 3 * len(typical)) / len(typical)
    assert typical.mean() > 0.1


def test_laser_slam_keeps_the_odometry_along_a_featureless_corridor():
    """``sim:laser`` ``corridor`` (seed 0), laser graph SLAM with degeneracy on and the interval covariance: the largest
    error along the featureless stretch (x 41–64 m, first pass) stays at the odometry's level (measured 0.130 against
    the odometry's 0.133 m)."""
    from test_degeneracy import _along_error  # tests/mapping is on sys.path (pytest prepend import mode)

    from slamarena.mapping.laser_slam.slam import LaserSLAM

    seq = simulate(world="corridor", seed=0)
    poses = LaserSLAM(**DEGENERATE).run(seq).poses
    assert _along_error(seq, poses) < 1.5 * _along_error(seq, seq.scans.pose) + 0.05


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
    with a corridor match (no information along it). With window floors below the caps (0.5 m, 0.05 rad; shipped at
    the caps, research/method/loop_verification.md) the loop search's half-width for node n against node 0 grows
    with the distance driven and falls back once a loop joins n to 0."""
    from slamarena.mapping.laser_slam.backend import Backend
    from slamarena.mapping.laser_slam.consistency import OdometryChain
    from slamarena.mapping.laser_slam.loop_closure import LoopCloser, LoopClosureParams
    from slamarena.robust import RobustKernelParams

    params = LoopClosureParams(min_linear_window=0.5, min_angular_window=0.05)
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


def test_a_pairwise_registration_in_a_corridor_keeps_the_front_ends_pose_along_it():
    """The refinement's pairwise factor (``LaserSLAM._pairwise_kept``): for a corridor scan with the degeneracy test on
    it keeps the front end's relative pose along the corridor and states no information there (σ = 10³ m), the
    across and heading parts as registered; a room scan, or the test off, leaves the registration as it was."""
    from test_degeneracy import _scan

    from slamarena.mapping.laser_slam.slam import LaserSLAM

    pts = np.ascontiguousarray(_scan("corridor", np.array([40.3, 2.0, 0.0]))[0])
    guess, z = np.array([0.30, 0.01, 0.002]), np.array([0.42, 0.012, 0.003])  # the ICP slid 12 cm along
    cov = np.diag([0.05**2, 0.002**2, 0.001**2])
    on = LaserSLAM(frontend={"matcher_params": {"degeneracy_threshold": 0.003}})
    kept_z, kept_cov = on._pairwise_kept(pts, guess, z, cov)
    assert kept_z[0] == pytest.approx(0.30, abs=0.005) and kept_z[1:] == pytest.approx(z[1:], abs=0.005)
    info = np.linalg.inv(kept_cov)  # (its marginal across is wide: u_0 is tilted by the normals' noise)
    assert info[0, 0] < 0.05 / cov[0, 0] and info[1, 1] > 0.5 / cov[1, 1] and info[2, 2] > 0.5 / cov[2, 2]
    off_z, off_cov = LaserSLAM()._pairwise_kept(pts, guess, z, cov)
    assert off_z is z and off_cov is cov
    room = np.ascontiguousarray(_scan("rooms", np.array([11.0, 6.45, 0.02]))[0])
    room_z, room_cov = on._pairwise_kept(room, guess, z, cov)
    assert room_z is z and room_cov is cov


def test_fixed_windows_need_no_marginal():
    """With the floors at the caps (shipped) every window is the caps whatever the covariance, so the candidates are
    chosen without asking for the joint marginal; with floors below the caps it is asked for."""
    from types import SimpleNamespace

    from slamarena.mapping.laser_slam.loop_closure import LoopCloser, LoopClosureParams

    submaps = [SimpleNamespace(index=s, finished=True, nodes=list(range(10 * s, 10 * s + 10))) for s in range(3)]
    G = np.column_stack([np.arange(31) * 0.4, np.zeros(31), np.zeros(31)])
    G[30] = [1.0, 0.5, 0.0]  # node 30 back near the start

    def no_marginal(c, n, covariance):
        assert not covariance, "the marginal was asked for"

    shipped = LoopCloser(LoopClosureParams())
    assert shipped.fixed and shipped.window(None) == (5.0, 0.5)
    found = shipped.candidates(submaps, 30, G, no_marginal)
    assert [s for s, _, P in found] == [0, 1] and all(P is None for *_, P in found)
    asked = []
    floors = LoopCloser(LoopClosureParams(min_linear_window=0.5, min_angular_window=0.05))
    assert not floors.fixed
    floors.candidates(submaps, 30, G, lambda c, n, covariance: asked.append(covariance) or np.eye(3) * 1e-4)
    assert asked and all(asked)
