"""Degeneracy-aware matching (research/method/laser_degeneracy.md): the odometry prior fused with the scan in information
form (against the literal objective and the literal posterior), the degenerate direction of a corridor found from the
scan's geometry and kept at the odometry guess, the covariance's eigen-directions along the corridor, and the
``sim:laser`` corridor world, where the error along the corridor stays at the odometry's level."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.geometry import transform_points
from slamarena.datasets.sim.laser import raycast, segments, simulate
from slamarena.mapping.map_pyramid import MapPyramid
from slamarena.mapping.odometry import MotionNoiseParams
from slamarena.mapping.scan_matching.gauss_newton import (
    GaussNewtonMatcher,
    degenerate_basis,
    interpolate,
    scan_information,
    solve_level,
)

ANGLES = np.linspace(-0.75 * np.pi, 0.75 * np.pi, 361)
ODOMETRY = MotionNoiseParams(sigma_t_min=0.02, sigma_t_per_m=0.0, sigma_t_per_rad=0.0, sigma_r_min=0.02)


def _scan(world, pose, max_range=12.0, rotate=0.0):
    """End points (N, 2) in the robot frame and the ranges of a noiseless scan of ``world`` from ``pose``."""
    r = raycast(pose[None, :2], pose[None, 2:3] + ANGLES[None, :], _walls(world, rotate), max_range)[0]
    ok = np.isfinite(r)
    return np.column_stack([r[ok] * np.cos(ANGLES[ok]), r[ok] * np.sin(ANGLES[ok])]), np.where(ok, r, max_range)


def _walls(world, rotate):
    """The world's segments (S, 4) rotated by ``rotate`` about the origin."""
    seg = segments(world).reshape(-1, 2)
    c, s = np.cos(rotate), np.sin(rotate)
    return (seg @ np.array([[c, s], [-s, c]])).reshape(-1, 4)


def _map(world, poses, rotate=0.0):
    maps = MapPyramid(resolution=0.05, levels=3, size=60.0, centre=tuple(poses[0][:2]))
    for pose in poses:
        _, r = _scan(world, pose, rotate=rotate)
        maps.integrate(r, ANGLES, pose, max_range=12.0)
    return maps


def _rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


@pytest.fixture(scope="module")
def room():
    """A map of the ``rooms`` world from four poses along its corridor, and a scan from between them."""
    poses = np.array([[8.0, 6.5, 0.0], [10.0, 6.5, 0.05], [12.0, 6.4, -0.05], [14.0, 6.5, 0.0]])
    truth = np.array([11.0, 6.45, 0.02])
    return _map("rooms", poses), _scan("rooms", truth)[0], truth


@pytest.mark.parametrize("drop", [False, True])
def test_the_fused_step_and_covariance_are_the_literal_information_form(room, drop):
    """One Gauss-Newton step of the matcher with an odometry prior is the literal step of the fused objective
    ½ Σ r_i² + ½ σ̂² eᵀ Σ_u⁻¹ e (σ̂² at the guess), d = A⁻¹ b with A = JᵀJ + σ̂² Σ_u⁻¹ and b = Jᵀr + σ̂² Σ_u⁻¹ e (J of
    M by central differences); with a dropped direction t_0 the literal constrained step T_k (T_kᵀ A T_k)⁻¹ T_kᵀ b over
    the kept columns T_k. The covariance handed on at the match is the literal posterior (H/σ̂² + Σ_u⁻¹)⁻¹ (with the
    scan's information projected onto the kept directions when one is dropped)."""
    maps, pts, truth = room
    guess = truth + [0.04, -0.03, 0.02]
    prior_cov = np.diag([0.03, 0.03, 0.02]) ** 2
    matcher = GaussNewtonMatcher(degeneracy_threshold=0.0)
    g = maps.finest
    pts = np.ascontiguousarray(pts)
    fusion = degenerate_basis(g, pts, guess, prior_cov, matcher.params)
    if drop:
        fusion.keep = np.array([0.0, 1.0, 1.0])
    info = np.linalg.inv(prior_cov)

    def occupancy(xi):
        return interpolate(g.log_odds, g.origin[0], g.origin[1], g.params.resolution, transform_points(xi, pts))[:, 0]

    def jacobian(xi, h=1e-7):
        return np.column_stack([(occupancy(xi + d) - occupancy(xi - d)) / (2 * h) for d in h * np.eye(3)])

    xi = guess + [-0.013, 0.011, -0.004]  # off the guess: the prior term has a gradient too
    W = fusion.s2 * fusion.info
    step, *_ = solve_level(
        g.log_odds,
        g.origin[0],
        g.origin[1],
        g.params.resolution,
        pts,
        xi,
        1,
        0.0,
        0.0,
        1.0,
        1.0,
        False,
        guess,
        W,
        fusion.T,
        fusion.keep,
        0,
    )
    J, r = jacobian(xi), 1.0 - occupancy(xi)
    A = J.T @ J + fusion.s2 * info
    b = J.T @ r + fusion.s2 * info @ (guess - xi)
    Tk = fusion.T[:, fusion.keep == 1.0]
    literal = Tk @ np.linalg.solve(Tk.T @ A @ Tk, Tk.T @ b)
    assert np.allclose(step - xi, literal, rtol=1e-4, atol=1e-9)
    # the covariance at the match, literally
    result = GaussNewtonMatcher(degeneracy_threshold=0.0).match(maps, pts, guess, prior_cov=prior_cov)
    M = occupancy(result.pose)
    J = jacobian(result.pose)
    s2 = np.sum((1 - M) ** 2) / (len(M) - 3)
    P = info @ Tk @ Tk.T  # projects the scan's information onto the kept directions (T⁻¹ = Tᵀ Σ_u⁻¹)
    literal_cov = np.linalg.inv(P @ (J.T @ J / s2) @ P.T + info)
    assert np.allclose(fusion.covariance(J.T @ J, s2 * (len(M) - 3), len(M)), literal_cov, rtol=1e-9)
    if not drop:
        assert np.allclose(result.cov, literal_cov, rtol=1e-3)


def test_the_covariance_with_a_dropped_direction_is_the_literal_posterior():
    """Σ = T (K Tᵀ(H/σ̂²)T K + I)⁻¹ Tᵀ equals the literal (Σ_u⁻¹ T K Tᵀ (H/σ̂²) T K Tᵀ Σ_u⁻¹ + Σ_u⁻¹)⁻¹ (T⁻¹ = Tᵀ Σ_u⁻¹):
    the scan's information projected onto the kept directions plus the odometry's."""
    from scipy.linalg import eigh

    from slamarena.mapping.scan_matching.gauss_newton import Fusion

    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    H = A @ A.T * 1e4
    info = np.linalg.inv(np.diag([0.02, 0.03, 0.01]) ** 2)
    I_s = np.diag([1.0, 5e4, 4e5])
    lam, T = eigh(I_s, info)
    keep = (lam >= 1.0).astype(float)
    assert keep.tolist() == [0.0, 1.0, 1.0]
    fusion = Fusion(info=info, s2=0.05, T=T, lam=lam, keep=keep)
    cov = fusion.covariance(H, ssr=0.05 * 97, n=100)
    K = np.diag(keep)
    literal = np.linalg.inv(info @ T @ K @ T.T @ (H / 0.05) @ T @ K @ T.T @ info + info)
    assert np.allclose(cov, literal, rtol=1e-9)


@pytest.mark.parametrize("rotate", [0.0, 0.6])
def test_a_corridor_scan_is_degenerate_along_the_corridor_and_the_covariance_says_so(rotate):
    """A scan between the corridor's two walls, far from its ends: the scan's geometric information has one direction
    below the odometry's, along the corridor (at any heading of the corridor in the world); the match keeps that
    direction at the odometry guess and corrects the others to the truth, and the covariance handed on has its major
    axis along the corridor with the odometry's variance there."""
    along = np.array([np.cos(rotate), np.sin(rotate)])
    poses = [np.array([*(_rot(rotate) @ [x, 2.0]), rotate]) for x in (36.0, 38.0, 40.0)]
    maps = _map("corridor", poses, rotate=rotate)
    truth = np.array([*(_rot(rotate) @ [40.3, 2.0]), rotate])
    pts, _ = _scan("corridor", truth, rotate=rotate)
    I_s = scan_information(pts, truth)
    w, V = np.linalg.eigh(I_s[:2, :2])
    assert abs(V[:, 0] @ along) > 0.999 and w[0] < 1e-6 * w[1]
    guess = truth + np.array([*(0.08 * along + 0.05 * np.array([-along[1], along[0]])), 0.01])
    prior_cov = ODOMETRY.cov(np.zeros(3))
    result = GaussNewtonMatcher().match(maps, pts, guess, prior_cov=prior_cov)
    assert result.info["degenerate"] == 1
    error = result.pose - truth
    assert abs(error[:2] @ along - 0.08) < 0.002  # along: the guess (the kept directions are Σ_u-orthogonal to it)
    assert abs(error[:2] @ [-along[1], along[0]]) < 0.01 and abs(error[2]) < 0.002  # across and heading: the scan
    w, V = np.linalg.eigh(result.cov[:2, :2])
    assert abs(V[:, 1] @ along) > 0.999
    assert w[1] == pytest.approx(0.02**2, rel=0.05)  # the odometry's variance along the corridor
    assert w[0] < 0.1 * w[1]  # across: the scan (σ ≈ 4 mm)


def test_a_match_does_not_depend_on_the_branch_cut():
    """The same scene at headings just below π and the guess given as θ and θ − 2π: the same pose (mod 2π), and the
    match is a descent (no two-cycle on the bilinear map's kinks: the objective at the result is below the guess's)."""
    rotate = np.pi - 1e-3
    poses = [np.array([*(_rot(rotate) @ [x, 2.0]), rotate]) for x in (6.0, 7.0, 8.0)]
    maps = _map("corridor", poses, rotate=rotate)
    truth = np.array([*(_rot(rotate) @ [7.5, 2.1]), rotate])
    pts, _ = _scan("corridor", truth, rotate=rotate)
    guess = truth + [0.03, -0.02, 0.01]
    matcher = GaussNewtonMatcher()
    a = matcher.match(maps, pts, guess)
    b = matcher.match(maps, pts, guess - [0.0, 0.0, 2 * np.pi])
    assert np.abs(a.pose[:2] - b.pose[:2]).max() < 1e-9
    assert abs(np.angle(np.exp(1j * (a.pose[2] - b.pose[2])))) < 1e-9
    assert -np.pi < a.pose[2] <= np.pi and -np.pi < b.pose[2] <= np.pi


def _along_error(sequence, estimate):
    """The largest |error along x| on the first corridor's featureless stretch (x from 41 to 64 m, the first pass),
    relative to its value at the stretch's start."""
    gt = sequence.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, sequence.scans.t)]
    first = np.arange(len(truth)) < np.argmax(truth[:, 1] > 3.0)
    on = first & (truth[:, 0] > 41.0) & (truth[:, 0] < 64.0)
    e = estimate[on, 0] - truth[on, 0]
    return float(np.abs(e - e[0]).max())


def test_along_a_featureless_corridor_the_error_stays_at_the_odometrys():
    """``sim:laser`` world ``corridor``: along its featureless stretch only the odometry sees the motion. Grid SLAM's
    front end (this matcher with the odometry prior) keeps the error along the corridor at the odometry's level; the
    match without the degeneracy handling (τ = 0, plain fusion) is dragged back by the map's frontier and falls metres
    behind."""
    from slamarena.mapping.grid_slam import GridSLAM

    seq = simulate(world="corridor", seed=0)
    odometry = _along_error(seq, seq.scans.pose)
    front = GridSLAM().run(seq).poses
    assert _along_error(seq, front) < 1.5 * odometry + 0.05
    plain = GridSLAM(frontend={"matcher_params": {"degeneracy_threshold": 0.0}}).run(seq).poses
    assert _along_error(seq, plain) > 10 * odometry
