"""Degeneracy-aware matching (research/method/laser_degeneracy.md): the step and covariance of a degenerate match
against their literal forms, the degenerate direction of a corridor found from the scan's geometry and kept at the
odometry guess, the covariance's eigen-directions along the corridor, the match independent of the angle's branch cut,
and the ``sim:laser`` corridor world, where the error along the corridor stays at the odometry's level."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.geometry import transform_points
from slamarena.datasets.sim.laser import raycast, segments, simulate
from slamarena.mapping.map_pyramid import MapPyramid
from slamarena.mapping.scan_matching.gauss_newton import (
    GaussNewtonMatcher,
    degenerate_basis,
    interpolate,
    scan_information,
    solve_level,
)

ANGLES = np.linspace(-0.75 * np.pi, 0.75 * np.pi, 361)
DEGENERACY = 0.003  # τ, as research/method/laser_degeneracy.md chose it on the simulated worlds


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


@pytest.fixture(scope="module")
def corridor():
    """A map of the corridor world from three poses along its first corridor, and a noiseless scan 0.3 m ahead."""
    poses = [np.array([x, 2.0, 0.0]) for x in (36.0, 38.0, 40.0)]
    truth = np.array([40.3, 2.0, 0.0])
    return _map("corridor", poses), np.ascontiguousarray(_scan("corridor", truth)[0]), truth


def test_a_degenerate_step_and_covariance_are_their_literal_forms(corridor):
    """One Gauss-Newton step of a degenerate match is the literal constrained step of ½ Σ r_i² + ½ eᵀWe over the kept
    directions, T_k (T_kᵀ A T_k)⁻¹ T_kᵀ b with A = JᵀJ + W, b = Jᵀr + We (J of M by central differences); the covariance
    handed on is the literal posterior (P (H/σ̂²) Pᵀ + Λ)⁻¹ with Λ = W/σ̂² the odometry's information and P = T K Tᵀ the
    projection onto the kept directions."""
    maps, pts, truth = corridor
    guess = truth + [0.08, 0.05, 0.01]
    matcher = GaussNewtonMatcher(degeneracy_threshold=DEGENERACY)
    g = maps.finest
    fusion = degenerate_basis(g, pts, guess, matcher.params)
    assert fusion is not None and fusion.keep.tolist() == [0.0, 1.0, 1.0]
    W = fusion.s2 * fusion.info

    def occupancy(xi):
        return interpolate(g.log_odds, g.origin[0], g.origin[1], g.params.resolution, transform_points(xi, pts))[:, 0]

    def jacobian(xi, h=1e-7):
        return np.column_stack([(occupancy(xi + d) - occupancy(xi - d)) / (2 * h) for d in h * np.eye(3)])

    xi = guess + [-0.013, 0.011, -0.004]  # off the guess: the prior term has a gradient too
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
    A, b = J.T @ J + W, J.T @ r + W @ (guess - xi)
    Tk = fusion.T[:, 1:]
    assert np.allclose(step - xi, Tk @ np.linalg.solve(Tk.T @ A @ Tk, Tk.T @ b), rtol=1e-4, atol=1e-9)
    result = matcher.match(maps, pts, guess, odometry=True)
    J, M = jacobian(result.pose), occupancy(result.pose)
    s2 = np.sum((1 - M) ** 2) / (len(M) - 3)
    P = Tk @ Tk.T
    literal = np.linalg.inv(P @ (J.T @ J / s2) @ P.T + fusion.info)
    assert np.allclose(result.cov, literal, rtol=1e-3)


@pytest.mark.parametrize("rotate", [0.0, 0.6])
def test_a_corridor_scan_is_degenerate_along_the_corridor_and_the_covariance_says_so(rotate):
    """A scan between the corridor's two walls, far from its ends (at any heading of the corridor in the world): the
    translation information of the scan's geometry has one direction with almost none, along the corridor; the match
    keeps the guess's offset along it and corrects across and in heading to the truth; the covariance handed on has its
    major axis along the corridor with the odometry's variance σ̂²/w_t there. A room scan is not degenerate."""
    along = np.array([np.cos(rotate), np.sin(rotate)])
    poses = [np.array([*(_rot(rotate) @ [x, 2.0]), rotate]) for x in (36.0, 38.0, 40.0)]
    maps = _map("corridor", poses, rotate=rotate)
    truth = np.array([*(_rot(rotate) @ [40.3, 2.0]), rotate])
    pts, _ = _scan("corridor", truth, rotate=rotate)
    w, V = np.linalg.eigh(scan_information(pts, truth)[:2, :2])
    assert abs(V[:, 0] @ along) > 0.999 and w[0] < 1e-6 * w[1]
    guess = truth + np.array([*(0.08 * along + 0.05 * np.array([-along[1], along[0]])), 0.01])
    matcher = GaussNewtonMatcher(degeneracy_threshold=DEGENERACY)
    result = matcher.match(maps, pts, guess, odometry=True)
    assert result.info["degenerate"] == 1
    error = result.pose - truth
    assert abs(error[:2] @ along - 0.08) < 1e-3  # along: the guess (up to u_0's tilt from the normals)
    across = error[:2] @ [-along[1], along[0]]
    assert abs(across) < 0.025 and abs(error[2]) < 0.008  # from 5 cm and 10 mrad: the scan corrects them
    w, V = np.linalg.eigh(result.cov[:2, :2])
    assert abs(V[:, 1] @ along) > 0.999
    s2 = degenerate_basis(maps.finest, np.ascontiguousarray(pts), guess, matcher.params).s2
    assert w[1] == pytest.approx(s2 / matcher.params.prior_translation_weight, rel=1e-6)
    assert w[0] < 0.01 * w[1]


def test_a_room_scan_is_not_degenerate(room):
    maps, pts, truth = room
    matcher = GaussNewtonMatcher(degeneracy_threshold=DEGENERACY)
    assert degenerate_basis(maps.finest, np.ascontiguousarray(pts), truth, matcher.params) is None
    plain = GaussNewtonMatcher().match(maps, pts, truth + [0.04, -0.03, 0.02])
    assert np.array_equal(matcher.match(maps, pts, truth + [0.04, -0.03, 0.02], odometry=True).pose, plain.pose)


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
    front end with the degeneracy handling keeps the error along the corridor at the odometry's level; without it
    (τ = 0, the default) the match is dragged back by the map's frontier and falls metres behind."""
    from slamarena.mapping.grid_slam import GridSLAM

    seq = simulate(world="corridor", seed=0)
    odometry = _along_error(seq, seq.scans.pose)
    front = GridSLAM(frontend={"matcher_params": {"degeneracy_threshold": DEGENERACY}}).run(seq).poses
    assert _along_error(seq, front) < 1.5 * odometry + 0.05
    plain = GridSLAM().run(seq).poses
    assert _along_error(seq, plain) > 10 * odometry
