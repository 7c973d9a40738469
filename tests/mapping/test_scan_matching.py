"""Scan matchers: gradients, the Hector objective and its errata, offsets recovered on hand-made,
simulated and real (corrected-log) scans, branch and bound = exhaustive search, covariances."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import WALLS, raycast
from pydantic import ValidationError

from slamarena.datasets.geometry import between, transform_points
from slamarena.mapping.map_pyramid import MapPyramid
from slamarena.mapping.scan_matching import MATCHERS, make_matcher, matcher_class
from slamarena.mapping.scan_matching.gauss_newton import GaussNewtonMatcher, interpolate, solve_level
from slamarena.mapping.scan_matching.point_to_line import residuals_and_jacobian

ANGLES = np.linspace(-np.pi, np.pi, 360, endpoint=False)
ROOM_POSES = np.array([[-4.0, -3.5, 0.2], [-1.0, -3.0, 0.0], [2.0, -2.5, -0.3], [4.5, -3.0, 0.5], [-4.0, 2.5, -1.2]])


def scan_points(pose, walls=WALLS, angles=ANGLES, max_range=20.0):
    r = raycast(pose, angles, walls, max_range)
    ok = r < max_range
    return np.column_stack([r[ok] * np.cos(angles[ok]), r[ok] * np.sin(angles[ok])]), r


@pytest.fixture(scope="module")
def room_map():
    """A map of the hand-made room built with known poses."""
    maps = MapPyramid(resolution=0.05, levels=3, size=16.0)
    for pose in ROOM_POSES:
        maps.integrate(raycast(pose, ANGLES), ANGLES, pose, max_range=20.0)
    return maps


def grid_of(maps):
    g = maps.finest
    return g.log_odds, g.origin[0], g.origin[1], g.params.resolution


# --------------------------------------------------------------------------- gradients
def _fd_gradient(L, ox, oy, res, xy, bicubic=False, h=1e-6):
    """∇M at ``xy`` (N, 2) by central differences of the interpolated value M (N, 2)."""

    def value(at):
        return interpolate(L, ox, oy, res, at, False, bicubic)[:, 0]

    return np.column_stack([(value(xy + d) - value(xy - d)) / (2 * h) for d in ([h, 0], [0, h])])


def test_interpolation_gradient_matches_finite_differences_and_the_hector_bug_does_not(room_map):
    L, ox, oy, res = grid_of(room_map)
    rng = np.random.default_rng(0)
    # points near walls (where the map has gradients), off the cell lattice
    pts, _ = scan_points(ROOM_POSES[1])
    xy = transform_points(ROOM_POSES[1], pts)[::7] + rng.uniform(-0.03, 0.03, (len(pts[::7]), 2))
    fd = _fd_gradient(L, ox, oy, res, xy)
    good = interpolate(L, ox, oy, res, xy, False)[:, 1:]
    bug = interpolate(L, ox, oy, res, xy, True)[:, 1:]
    assert np.allclose(good, fd, atol=1e-4 * np.abs(fd).max())
    assert np.abs(bug - fd).max() > 0.1 * np.abs(fd).max()


def test_bug_and_correct_gradients_agree_on_the_diagonal_of_a_cell():
    """With f_x = f_y the two weightings coincide: the bug only shows off the diagonal."""
    L = np.array([[0.0, 2.0], [-1.0, 1.5]], dtype=np.float32)
    on = np.array([[0.5 * 1.0 + 0.3, 0.5 * 1.0 + 0.3]])  # cell-centre coordinates f_x = f_y = 0.3
    off = np.array([[0.8, 0.6]])
    args = (L, 0.0, 0.0, 1.0)
    assert np.allclose(interpolate(*args, on, False), interpolate(*args, on, True))
    assert not np.allclose(interpolate(*args, off, False), interpolate(*args, off, True))


def test_bicubic_passes_through_the_cells_and_is_c1_with_the_finite_difference_gradient(room_map):
    """Catmull-Rom: M at a cell centre is the cell's probability; ∇M is M's central difference; value and gradient are
    continuous where the interpolation patches meet, on the lines through the cell centres (bilinear's gradient is not)."""
    L, ox, oy, res = grid_of(room_map)
    rng = np.random.default_rng(1)
    pts, _ = scan_points(ROOM_POSES[1])
    xy = transform_points(ROOM_POSES[1], pts)[::5] + rng.uniform(-0.04, 0.04, (len(pts[::5]), 2))
    fd = _fd_gradient(L, ox, oy, res, xy, bicubic=True)
    assert np.allclose(interpolate(L, ox, oy, res, xy, False, True)[:, 1:], fd, atol=1e-4 * np.abs(fd).max())
    cells = np.floor((xy - [ox, oy]) / res).astype(int)  # the points' cells (column, row)
    centres = [ox, oy] + (cells + 0.5) * res
    assert np.allclose(
        interpolate(L, ox, oy, res, centres, False, True)[:, 0], 1 / (1 + np.exp(-L[cells[:, 1], cells[:, 0]]))
    )
    edges = centres + [0.0, 0.3 * res]  # on a line x = const through cell centres, where the patches meet
    eps = np.array([1e-9, 0.0])
    for cubic, continuous in ((True, True), (False, False)):
        jump = interpolate(L, ox, oy, res, edges + eps, False, cubic) - interpolate(
            L, ox, oy, res, edges - eps, False, cubic
        )
        assert np.abs(jump[:, 0]).max() < 1e-6
        assert (np.abs(jump[:, 1:]).max() < 1e-5) == continuous


# --------------------------------------------------------------------------- objective
def _objective(L, ox, oy, res, pts, pose):
    M = interpolate(L, ox, oy, res, transform_points(pose, pts))[:, 0]
    return float(np.sum((1.0 - M) ** 2)), float(np.sum(M**2))


def test_hector_objective_is_minimal_at_the_true_pose_and_the_notes_objective_is_not(room_map):
    """Σ[1 − M]² grows away from the true pose; the notes' Σ M² shrinks (scan pushed into free space)."""
    L, ox, oy, res = grid_of(room_map)
    pose = ROOM_POSES[2]
    pts, _ = scan_points(pose)
    hector0, notes0 = _objective(L, ox, oy, res, pts, pose)
    for d in ([0.04, 0, 0], [0, -0.04, 0], [0, 0, 0.02]):
        hector, notes = _objective(L, ox, oy, res, pts, pose + np.array(d))
        assert hector > hector0
        assert notes < notes0


def test_notes_update_rule_walks_away_from_the_map(room_map):
    """x ← x − (JᵀJ)⁻¹Jᵀ f with f = M (the notes) vs Δξ = H⁻¹ Σ Jᵀ(1 − M) (Hector), from a 3 cm error."""
    L, ox, oy, res = grid_of(room_map)
    truth = ROOM_POSES[2]
    pts, _ = scan_points(truth)

    def step(pose, notes):
        c, s = np.cos(pose[2]), np.sin(pose[2])
        V = interpolate(L, ox, oy, res, transform_points(pose, pts))
        J = np.column_stack(
            [V[:, 1], V[:, 2], V[:, 1] * (-s * pts[:, 0] - c * pts[:, 1]) + V[:, 2] * (c * pts[:, 0] - s * pts[:, 1])]
        )
        r = V[:, 0] if notes else 1.0 - V[:, 0]
        d = np.linalg.solve(J.T @ J, J.T @ r)
        return pose - d if notes else pose + d

    err = {}
    for notes in (False, True):
        pose = truth + np.array([0.03, -0.02, 0.01])
        for _ in range(5):
            pose = step(pose, notes)
        err[notes] = np.hypot(*(pose[:2] - truth[:2]))
    assert err[False] < 0.025 and err[True] > 0.1  # start: 0.036 m


# --------------------------------------------------------------------------- recover offsets
GRID_MATCHERS = [
    ("gauss_newton", {}),
    ("gauss_newton", {"line_search": True}),
    ("gauss_newton", {"line_search": True, "interpolation": "bicubic"}),
    ("gauss_newton", {"hector_gradient_bug": True}),
    ("correlative", {}),
    ("branch_and_bound", {}),
]
POINT_MATCHERS = [
    ("kiss_icp", {}),
    ("open3d_icp", {"method": "point_to_point"}),
    ("open3d_icp", {"method": "point_to_plane"}),
    ("open3d_icp", {"method": "generalized"}),
    ("point_to_line", {}),
]


@pytest.mark.parametrize("name,params", GRID_MATCHERS + POINT_MATCHERS)
def test_matchers_recover_a_known_offset_in_the_room(room_map, name, params):
    m = make_matcher(name, **params)
    truth = np.array([0.5, -3.2, 0.1])
    pts, _ = scan_points(truth, angles=np.linspace(-np.pi / 2, np.pi / 2, 181))
    ref = room_map if m.kind == "grid" else np.concatenate([transform_points(p, scan_points(p)[0]) for p in ROOM_POSES])
    # the correlative matchers search a lattice of whole cells around the guess: error ≤ ½ cell diagonal
    tol = 0.5 * np.hypot(0.05, 0.05) + 0.01 if name in ("correlative", "branch_and_bound") else 0.03
    for offset in ([0.12, -0.08, 0.05], [-0.07, 0.1, -0.06]):
        res = m.match(ref, pts, truth + np.array(offset))
        e = between(truth, res.pose)
        assert np.hypot(e[0], e[1]) < tol and abs(e[2]) < 0.01, (name, params, e)
        assert np.all(np.isfinite(res.cov)) and np.all(np.linalg.eigvalsh(res.cov) > 0)


def test_branch_and_bound_equals_exhaustive_search(room_map):
    rng = np.random.default_rng(3)
    ex = make_matcher("correlative", linear_window=0.25, angular_window=0.15)
    bb = make_matcher("branch_and_bound", linear_window=0.25, angular_window=0.15)
    for _ in range(4):
        truth = np.array([rng.uniform(-4, 4), rng.uniform(-4, -2.5), rng.uniform(-np.pi, np.pi)])
        pts, _ = scan_points(truth)
        guess = truth + rng.uniform(-0.2, 0.2, 3) * [1, 1, 0.5]
        a, b = ex.match(room_map, pts, guess), bb.match(room_map, pts, guess)
        assert a.score == pytest.approx(b.score, abs=1e-9)
        assert np.allclose(a.pose, b.pose)
        assert b.iterations < a.iterations / 4  # candidates scored


def test_covariance_is_long_along_a_corridor():
    """Two parallel walls constrain y and θ, not x: the covariances say so."""
    corridor = np.array([[-20, -1.0, 20, -1.0], [-20, 1.0, 20, 1.0]]) + 0.013
    angles = np.linspace(-1.2, 1.2, 121)
    maps = MapPyramid(resolution=0.05, levels=2, size=24.0)
    for x in np.arange(-8.0, 8.1, 1.0):  # the walls mapped far beyond what the scan sees
        maps.integrate(raycast(np.array([x, 0, 0]), ANGLES, corridor, 8.0), ANGLES, np.array([x, 0, 0]), max_range=8.0)
    pts, _ = scan_points(np.array([0.2, 0.0, 0.0]), corridor, angles, 4.0)
    for name in ("gauss_newton", "correlative"):
        res = make_matcher(name, linear_window=0.2, angular_window=0.1) if name == "correlative" else make_matcher(name)
        out = res.match(maps, pts, np.array([0.2, 0.03, 0.0]))
        w, V = np.linalg.eigh(out.cov[:2, :2])
        assert abs(V[0, 1]) > 0.99 and w[1] > 4 * w[0], (name, out.cov)  # major axis along x


def test_point_to_line_residual_jacobian_matches_finite_differences():
    rng = np.random.default_rng(0)
    s, q = rng.uniform(-3, 3, (20, 2)), rng.uniform(-3, 3, (20, 2))
    n = rng.standard_normal((20, 2))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    pose = np.array([0.3, -0.2, 0.7])
    r, J = residuals_and_jacobian(pose, s, q, n)
    eps = 1e-6
    numeric = np.column_stack(
        [
            (residuals_and_jacobian(pose + e, s, q, n)[0] - residuals_and_jacobian(pose - e, s, q, n)[0]) / (2 * eps)
            for e in np.eye(3) * eps
        ]
    )
    np.testing.assert_allclose(J, numeric, atol=1e-7)
    assert np.allclose(r, np.sum(n * (transform_points(pose, s) - q), axis=1))


def test_point_to_line_kernel_equals_the_literal_brute_force_form():
    """The binned numba kernel (normals from the neighbours within the radius, the nearest paired point with a line,
    H = Σ JᵀJ, g = Σ Jᵀr) against brute force: all pairwise distances, eigh of each neighbourhood's covariance."""
    from slamarena.mapping.scan_matching.point_to_line import _normal_equations

    m = make_matcher("point_to_line")
    ref_pts = transform_points(ROOM_POSES[1], scan_points(ROOM_POSES[1])[0])
    ref = m.prepare(ref_pts)
    P = ref.points
    D = np.linalg.norm(P[:, None] - P[None], axis=2)
    normals = np.full_like(P, np.nan)
    for i, near in enumerate(D <= m.params.normal_radius):
        if near.sum() >= 3:
            normals[i] = np.linalg.eigh(np.cov(P[near].T, bias=True))[1][:, 0]
    has = ~np.isnan(ref.normals[:, 0])
    assert has.mean() > 0.9 and np.array_equal(has, ~np.isnan(normals[:, 0]))
    np.testing.assert_allclose(
        np.abs(np.sum(ref.normals[has] * normals[has], axis=1)), 1.0, atol=1e-9
    )  # the same line, either sign
    pose = ROOM_POSES[1] + np.array([0.04, -0.03, 0.02])
    pts = scan_points(ROOM_POSES[1] + np.array([0.3, 0.1, 0.05]))[0]
    world = transform_points(pose, pts)
    Dq = np.linalg.norm(world[:, None] - P[None], axis=2)
    Dq[:, ~has] = np.inf
    j = Dq.argmin(axis=1)
    paired = Dq[np.arange(len(world)), j] <= m.params.max_correspondence
    r, J = residuals_and_jacobian(pose, pts[paired], P[j[paired]], ref.normals[j[paired]])
    ny, nx = ref.shape
    H, g, ssr, n = _normal_equations(
        P, ref.normals, ref.start, ref.origin, ref.cell, nx, ny, pts, pose, m.params.max_correspondence
    )
    assert n == paired.sum() > 100
    np.testing.assert_allclose(H, J.T @ J, rtol=1e-10)
    np.testing.assert_allclose(g, J.T @ r, rtol=1e-10, atol=1e-12)
    assert ssr == pytest.approx(r @ r, rel=1e-10)


def test_point_to_line_covariance_is_long_along_a_corridor():
    """Scan onto scan in a corridor (5 mm noise on the points): the walls fix y and θ, not x. Without noise every
    normal is exactly ±y, H is singular and the covariance infinite (the pair is unusable)."""
    corridor = np.array([[-20, -1.0, 20, -1.0], [-20, 1.0, 20, 1.0]]) + 0.013
    rng = np.random.default_rng(2)
    m = make_matcher("point_to_line")
    ref, truth = scan_points(np.zeros(3), corridor, ANGLES, 8.0)[0], np.array([0.3, 0.02, 0.01])
    pts = scan_points(truth, corridor, ANGLES, 8.0)[0]
    exact = m.match(ref, pts, truth + np.array([0.0, 0.03, -0.01]))
    assert np.all(np.isinf(np.diag(exact.cov))) and exact.pose[0] == truth[0]  # x left at the guess, not thrown away
    assert abs(exact.pose[1] - truth[1]) < 1e-6 and abs(exact.pose[2] - truth[2]) < 1e-6
    out = m.match(
        ref + rng.normal(0, 0.005, ref.shape),
        pts + rng.normal(0, 0.005, pts.shape),
        truth + np.array([0.0, 0.03, -0.01]),
    )
    assert (
        abs(out.pose[1] - truth[1]) < 3e-3 and abs(out.pose[2] - truth[2]) < 2e-3
    )  # across the corridor and the heading
    w, V = np.linalg.eigh(out.cov[:2, :2])
    assert abs(V[0, 1]) > 0.99 and w[1] > 100 * w[0], out.cov  # major axis along x


# --------------------------------------------------------------------------- simulated and real scans
def test_matchers_recover_offsets_on_sim_laser():
    sim = pytest.importorskip("slamarena.datasets.sim.laser")
    seq = sim.simulate(laps=1, seed=4)
    sc, gt = seq.scans, seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, sc.t)]
    ks = np.arange(20, len(sc.t), 60)
    maps = MapPyramid(resolution=0.05, levels=2, size=40.0)
    for k in range(0, len(sc.t), 10):
        maps.integrate(*sc.beams(k), truth[k], sc.mount, max_range=sc.max_range)
    rng = np.random.default_rng(1)
    for name, params in [("gauss_newton", {}), ("branch_and_bound", {})]:
        m = make_matcher(name, **params)
        errs = []
        for k in ks:
            res = m.match(maps, _points(sc, k), truth[k] + rng.uniform(-1, 1, 3) * [0.1, 0.1, 0.04])
            e = between(truth[k], res.pose)
            errs.append([np.hypot(e[0], e[1]), abs(e[2])])
        errs = np.array(errs)
        assert np.median(errs[:, 0]) < 0.03 and np.median(errs[:, 1]) < 0.01, (name, errs)
        assert errs[:, 0].max() < 0.08, (name, errs)


@pytest.mark.realdata
def test_matchers_on_consecutive_corrected_intel_scans():
    """Scan k+1 matched against a map of scans k−3 … k at the corrected poses, from the corrected
    pose of k+1 plus an offset; compared with the corrected pose (a SLAM reference, itself
    uncertain by a few cm)."""
    from conftest_staged import corrected_intel

    sc = corrected_intel()
    offset = np.array([0.1, -0.08, 0.05])
    ks = range(104, 900, 80)
    for name, params, tol in [
        ("gauss_newton", {}, (0.07, 0.02)),
        ("branch_and_bound", {}, (0.05, 0.01)),
        ("kiss_icp", {}, (0.05, 0.01)),
        ("open3d_icp", {"method": "generalized"}, (0.05, 0.01)),
    ]:
        m = make_matcher(name, **params)
        errs = []
        for k in ks:
            pts = [_points(sc, j) for j in range(k - 3, k + 2)]
            if m.kind == "grid":
                ref = MapPyramid(resolution=0.05, levels=2, size=40.0)
                for j in range(k - 3, k + 1):
                    ref.integrate(*sc.beams(j), sc.pose[j], sc.mount, max_range=sc.max_range, clear_range=5.0)
            else:
                ref = np.concatenate([transform_points(sc.pose[j], pts[i]) for i, j in enumerate(range(k - 3, k + 1))])
            res = m.match(ref, pts[-1], sc.pose[k + 1] + offset)
            e = between(sc.pose[k + 1], res.pose)
            errs.append([np.hypot(e[0], e[1]), abs(e[2])])
        med = np.median(errs, axis=0)
        assert med[0] < tol[0] and med[1] < tol[1], (name, med)
        assert med[0] < 0.5 * np.hypot(*offset[:2]) and med[1] < 0.5 * offset[2]


def _points(sc, k):
    r, a = sc.beams(k)
    ok = (r > 0) & (r < sc.max_range)
    return transform_points(sc.mount, np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])]))


def test_registry_and_bad_parameters():
    assert set(MATCHERS) == {
        "gauss_newton",
        "correlative",
        "branch_and_bound",
        "kiss_icp",
        "open3d_icp",
        "point_to_line",
    }
    with pytest.raises(KeyError):
        make_matcher("ndt")
    with pytest.raises(ValueError):
        make_matcher("gauss_newton", iterations=0)
    with pytest.raises(ValueError):
        make_matcher("correlative", sigma=0)
    with pytest.raises(ValueError):
        make_matcher("open3d_icp", method="colored")


PARAMETER_CASES = [  # (matcher, a valid non-default parameter, a bad value)
    ("gauss_newton", {"prior_rotation_weight": 0.0}, {"max_step_rotation": 0.0}),
    ("correlative", {"angular_step": 0.01}, {"p_floor": 1.0}),
    ("branch_and_bound", {"covariance_cells": 3}, {"linear_window": -0.1}),
    ("kiss_icp", {"voxel_size": 0.2}, {"max_points_per_voxel": 0}),
    ("open3d_icp", {"method": "generalized"}, {"neighbours": 2}),
    ("point_to_line", {"normal_radius": 0.3}, {"max_correspondence": 0.0}),
]


@pytest.mark.parametrize("name,good,bad", PARAMETER_CASES)
def test_parameters_bad_values_unknown_keys_and_the_model_form(name, good, bad):
    cls = matcher_class(name)
    (field,) = bad
    with pytest.raises(ValidationError, match=field):
        make_matcher(name, **bad)
    with pytest.raises(ValidationError, match="no_such_parameter"):
        cls(no_such_parameter=1)
    ((key, value),) = good.items()
    m = make_matcher(name, **good)
    assert getattr(m.params, key) == value != getattr(cls().params, key)
    assert cls(cls.Params(**good)).params == m.params


def test_the_hector_gradient_bug_is_bilinear_only():
    with pytest.raises(ValidationError, match="hector_gradient_bug"):
        make_matcher("gauss_newton", interpolation="bicubic", hector_gradient_bug=True)


def test_the_covariance_window_belongs_to_branch_and_bound_only():
    """The exhaustive search takes its covariance from the whole response: ``covariance_cells`` is no parameter of it."""
    assert make_matcher("branch_and_bound", covariance_cells=1).params.covariance_cells == 1
    with pytest.raises(ValidationError, match="covariance_cells"):
        make_matcher("correlative", covariance_cells=1)


def test_refined_correlative_match_leaves_the_lattice(room_map):
    truth = np.array([0.5, -3.2, 0.1])
    pts, _ = scan_points(truth, angles=np.linspace(-np.pi / 2, np.pi / 2, 181))
    guess = truth + np.array([0.12, -0.08, 0.05])
    coarse = make_matcher("branch_and_bound").match(room_map, pts, guess)
    fine = make_matcher("branch_and_bound", refine=True).match(room_map, pts, guess)
    assert np.allclose(fine.info["lattice_pose"], coarse.pose)
    assert np.allclose(fine.pose, make_matcher("gauss_newton").match(room_map, pts, coarse.pose).pose)
    steps = (fine.pose[:2] - guess[:2]) / 0.05
    assert np.abs(steps - np.round(steps)).max() > 0.05  # off the lattice of whole cells
    e = between(truth, fine.pose)
    assert np.hypot(e[0], e[1]) < 0.03 and abs(e[2]) < 0.01


# --------------------------------------------------------------------------- convergence
def _cycle_case():
    """A scan of the room (181 beams, 1 cm range noise) and a guess 3 cm / 1° off where Hector's undamped iteration on the
    bilinear map two-cycles (found by a search over random poses; research/notebook/2026-11-28-matcher-convergence.md)."""
    rng = np.random.default_rng(0)
    truth = np.array([rng.uniform(-5, 0), rng.uniform(-4, 4), rng.uniform(-np.pi, np.pi)])
    angles = np.linspace(-np.pi / 2, np.pi / 2, 181)
    r = raycast(truth, angles)
    ok = r < 20.0
    r = r + 0.01 * rng.standard_normal(r.shape)
    pts = np.column_stack([r[ok] * np.cos(angles[ok]), r[ok] * np.sin(angles[ok])])
    return truth, pts, truth + rng.normal(0.0, [0.03, 0.03, 0.02])


def _hector_iterates(L, ox, oy, res, pts, guess, W, n):
    """n undamped Gauss-Newton steps of ½Σ(1 − M)² + ½eᵀWe on the bilinear map, clamped as the matcher clamps (literal)."""
    xi = guess.copy()
    out = [xi]
    for _ in range(n):
        c, s = np.cos(xi[2]), np.sin(xi[2])
        V = interpolate(L, ox, oy, res, transform_points(xi, pts))
        J = np.column_stack(
            [V[:, 1], V[:, 2], V[:, 1] * (-s * pts[:, 0] - c * pts[:, 1]) + V[:, 2] * (c * pts[:, 0] - s * pts[:, 1])]
        )
        d = np.linalg.solve(J.T @ J + W, J.T @ (1.0 - V[:, 0]) + W @ (guess - xi))
        d[:2] *= min(1.0, 0.1 / np.hypot(d[0], d[1]))
        d[2] = np.clip(d[2], -0.2, 0.2)
        xi = xi + d
        out.append(xi)
    return np.array(out)


@pytest.mark.parametrize("interpolation", ["bilinear", "bicubic"])
def test_where_hectors_iteration_two_cycles_the_matcher_converges(room_map, interpolation):
    """On the finest level from the same guess: the undamped iteration alternates between two poses centimetres apart
    up to any cap; the matcher's iteration (line search) stops on its tolerance, at a stationary point of F."""
    L, ox, oy, res = grid_of(room_map)
    truth, pts, guess = _cycle_case()
    p = GaussNewtonMatcher(interpolation=interpolation, line_search=True).params
    W = np.diag([p.prior_translation_weight, p.prior_translation_weight, p.prior_rotation_weight])
    hector = _hector_iterates(L, ox, oy, res, pts, guess, W, 40)
    assert np.hypot(*(hector[-1] - hector[-2])[:2]) > 0.01  # still stepping by centimetres …
    assert np.abs(hector[-1] - hector[-3]).max() < 1e-6  # … back and forth
    args = (L, ox, oy, res, np.ascontiguousarray(pts), guess)
    tail = (
        p.tol_translation,
        p.tol_rotation,
        p.max_step_translation,
        p.max_step_rotation,
        p.kind,
        guess,
        W,
        np.eye(3),
        np.ones(3),
        p.line_search,
    )
    pose, H, ssr, _, n, iterations = solve_level(*args, 100, *tail)
    assert iterations < 30
    more, *_ = solve_level(L, ox, oy, res, np.ascontiguousarray(pts), pose, 100, *tail)
    assert np.hypot(*(more - pose)[:2]) < 2 * p.tol_translation
    assert np.hypot(*(pose - truth)[:2]) < 0.02


def test_a_last_bit_or_a_turn_of_the_guess_does_not_move_the_bicubic_match(room_map):
    """On the C¹ map the match is a smooth function of its guess: 10⁻¹² on every component, or the heading a turn away
    (±2π), moves it by less than 10⁻⁹ (the cells are 5 cm), in the scene where Hector's iteration two-cycles and in the
    room."""
    m = GaussNewtonMatcher(interpolation="bicubic", line_search=True)
    truth, pts, guess = _cycle_case()
    room_truth = np.array([0.5, -3.2, 0.1])
    room_pts, _ = scan_points(room_truth, angles=np.linspace(-np.pi / 2, np.pi / 2, 181))
    for pts, guess in ((pts, guess), (room_pts, room_truth + [0.12, -0.08, 0.05])):
        ref = m.match(room_map, pts, guess).pose
        for other in (guess + 1e-12, guess - 1e-12, guess + [0, 0, 2 * np.pi], guess - [0, 0, 2 * np.pi]):
            e = between(ref, m.match(room_map, pts, other).pose)
            assert np.hypot(e[0], e[1]) < 1e-9 and abs(e[2]) < 1e-9


class _Stop(Exception):
    pass


def test_on_mit_csail_the_bicubic_front_end_converges_and_a_last_bit_of_the_guess_does_not_move_it(monkeypatch):
    """Grid SLAM's front end on the staged MIT-CSAIL log, scans up to 700, bicubic map: Hector's iteration ran matches
    575–640 to the cap (61 of 66) and a last-bit change of a guess grew threefold per scan there (research/method/
    laser_degeneracy.md, "The branch cut"); now most stop on the tolerance, and 10⁻¹² added to every guess moves no
    front-end pose by 10⁻⁶ m (on the bilinear map the same runs part by metres: the notebook)."""
    from checks import load_staged

    from slamarena.mapping.grid_slam import GridSLAM

    seq = load_staged("carmen:mit-csail")
    match = GaussNewtonMatcher.match

    def front_end(perturbation):
        out = []

        def perturbed(self, maps, points, guess, odometry=False):
            result = match(self, maps, points, np.asarray(guess) + perturbation, odometry)
            out.append((result.pose, result.iterations))
            return result

        def stop(k, _):
            if k >= 700:
                raise _Stop

        monkeypatch.setattr(GaussNewtonMatcher, "match", perturbed)
        with pytest.raises(_Stop):
            GridSLAM(frontend={"matcher_params": {"interpolation": "bicubic", "line_search": True}}).run(
                seq, progress=stop
            )
        return np.array([p for p, _ in out]), np.array([i for _, i in out])

    poses, iterations = front_end(0.0)
    again, _ = front_end(1e-12)
    cap = 3 * GaussNewtonMatcher().params.iterations  # main's matcher: 61 of 66
    assert np.sum(iterations[575:641] == cap) < 15
    assert len(again) == len(poses) and np.abs(again - poses).max() < 1e-6
