"""The grid RBPF: copy-on-write tiles, resampling, the proposal, parameters, and the filter on simulated drives."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
from conftest import make_sequence
from pydantic import ValidationError

from slamarena.mapping.occupancy_grid import CellModelParams, OccupancyGrid
from slamarena.mapping.odometry import fresh_readings
from slamarena.mapping.rbpf import RBPF
from slamarena.mapping.rbpf.filter import systematic_resampling
from slamarena.mapping.rbpf.proposal import NODE_WEIGHTS, NODES
from slamarena.mapping.rbpf.tiled_grid import TiledGrid


def _scan(seq, k, limit=15.0, clear=5.0):
    r, a = seq.scans.beams(k)
    hit = r < limit
    return np.where(hit, r, np.minimum(r, clear)), a, hit, r


def _same_cells(tiled: OccupancyGrid, ref: OccupancyGrid) -> bool:
    """Cell for cell on the reference's lattice (the tiled grid is l0 wherever it does not reach)."""
    off = np.round((ref.origin - tiled.origin) / ref.params.resolution).astype(int)
    pad = 1000
    big = np.pad(tiled.log_odds, pad, constant_values=tiled.l0)
    h, w = ref.shape
    window = big[off[1] + pad : off[1] + pad + h, off[0] + pad : off[0] + pad + w]
    return np.array_equal(window, ref.log_odds) and np.count_nonzero(tiled.log_odds != tiled.l0) == np.count_nonzero(
        ref.log_odds != ref.l0
    )


@pytest.mark.parametrize("hit_guard", [0, 1])
def test_every_particle_map_equals_its_own_occupancy_grid_through_writes_and_resampling(room_sequence, hit_guard):
    """Random partial writes and resamplings: each particle's tiles equal a private OccupancyGrid (deep-copied
    at resampling) cell for cell, and the reference counts are the number of table entries naming a tile."""
    P = 4
    rng = np.random.default_rng(1)
    grid = TiledGrid(P, {"hit_guard": hit_guard}, 0.05, tile=16, size=2.0)
    refs = [
        OccupancyGrid(cells={"hit_guard": hit_guard}, resolution=0.05, width=40, height=40, origin=tuple(grid.origin))
        for _ in range(P)
    ]
    for k in range(0, 80, 3):
        reach, a, hit, r = _scan(room_sequence, k)
        poses = room_sequence.ground_truth.poses[k] + rng.normal(0, [0.05, 0.05, 0.02], (P, 3))
        which = rng.choice(P, size=rng.integers(1, P + 1), replace=False)
        grid.integrate(poses, reach, a, hit, which=which)
        for i in which:
            refs[i].integrate(r, a, poses[i], max_range=15.0, clear_range=5.0)
        if k % 9 == 0:
            ancestors = rng.integers(0, P, P)
            grid.resample(ancestors)
            refs = [copy.deepcopy(refs[i]) for i in ancestors]
        for i in range(P):
            assert _same_cells(grid.dense(i), refs[i]), (k, i)
        assert np.array_equal(grid.refs, np.bincount(grid.table[grid.table >= 0], minlength=grid.pool.shape[0]))
        assert grid.n_free[0] == np.count_nonzero(grid.refs == 0)


def test_a_write_to_one_particle_never_changes_another(room_sequence):
    P = 5
    grid = TiledGrid(P, {}, 0.05, tile=32, size=4.0)
    truth = room_sequence.ground_truth.poses
    reach, a, hit, _ = _scan(room_sequence, 0)
    grid.integrate(np.tile(truth[0], (P, 1)), reach, a, hit, which=[0])
    grid.resample(np.zeros(P, np.int64))  # every particle shares particle 0's tiles
    shared = grid.memory()
    assert shared["used"] * P < 1.1 * shared["unshared"]  # one copy of the tiles, P tables
    before = [grid.dense(i).log_odds.copy() for i in range(P)]
    reach, a, hit, _ = _scan(room_sequence, 30)
    grid.integrate(np.tile(truth[30], (P, 1)), reach, a, hit, which=[2])
    after = [grid.dense(i).log_odds for i in range(P)]
    for i in range(P):
        assert np.array_equal(after[i], before[i]) == (i != 2), i
    copied = np.flatnonzero((grid.table[2] != grid.table[0]).ravel())
    assert copied.size > 0 and np.all(
        grid.refs[grid.table[0].ravel()[copied][grid.table[0].ravel()[copied] >= 0]] == P - 1
    )
    assert grid.memory()["used"] > shared["used"]


def test_resampling_frees_tiles_nobody_names_and_reuses_them(room_sequence):
    P = 3
    grid = TiledGrid(P, {}, 0.05, tile=16, size=2.0)
    truth = room_sequence.ground_truth.poses
    for k in (0, 10, 20):
        reach, a, hit, _ = _scan(room_sequence, k)
        grid.integrate(truth[k] + np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]]), reach, a, hit)
    tiles = grid.pool.shape[0]
    private = np.setdiff1d(grid.table[1], np.concatenate([grid.table[0].ravel(), grid.table[2].ravel(), [-1]]))
    free = grid.n_free[0]
    grid.resample([0, 0, 2])  # particle 1's map is gone
    assert private.size > 0 and grid.n_free[0] == free + private.size
    reach, a, hit, _ = _scan(room_sequence, 30)
    grid.integrate(np.tile(truth[30], (P, 1)), reach, a, hit, which=[1])
    assert grid.pool.shape[0] == tiles  # the copies went into freed tiles


def test_tiles_must_be_a_power_of_two():
    with pytest.raises(ValueError, match="power of two"):
        TiledGrid(2, {}, 0.05, tile=48)


def test_systematic_resampling():
    rng = np.random.default_rng(0)
    assert np.array_equal(systematic_resampling(np.eye(6)[4], rng), np.full(6, 4))
    assert np.array_equal(systematic_resampling(np.full(6, 1 / 6), rng), np.arange(6))
    w = rng.dirichlet(np.ones(10))
    for _ in range(20):
        counts = np.bincount(systematic_resampling(w, rng), minlength=10)
        assert np.all((counts >= np.floor(10 * w)) & (counts <= np.ceil(10 * w)))  # low variance: ⌊Pw⌋ or ⌈Pw⌉ copies


def test_gauss_hermite_points_integrate_a_gaussian_exactly():
    """The 27 points and weights: Σ w = 1, Σ w u = 0, Σ w u uᵀ = I and fourth moments 3 (degree-5 exactness)."""
    assert NODES.shape == (27, 3) and np.isclose(NODE_WEIGHTS.sum(), 1.0)
    assert np.allclose(NODE_WEIGHTS @ NODES, 0.0)
    assert np.allclose(np.einsum("k,ki,kj->ij", NODE_WEIGHTS, NODES, NODES), np.eye(3))
    assert np.allclose(NODE_WEIGHTS @ NODES**4, 3.0)


def _target_state(k=150, particles=1):
    """One lap of the 4 m-laser loop world: the maps of ``particles`` particles (one map, shared) from the true poses of
    scans 0, 3, …, k − 3, scan k's end points (robot frame), a guess off the truth and a filter step's Σ_u (σ 0.15 m,
    0.13 rad)."""
    from slamarena.datasets.geometry import compose, transform_points
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.rbpf.tiled_grid import TiledPyramid

    seq = simulate(
        max_range=4.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=0.085, scan_rate=2.5, laps=1, seed=0
    )
    scans, p = seq.scans, RBPF.Params()
    truth = seq.ground_truth.poses[np.searchsorted(seq.ground_truth.t, scans.t)]
    pyramid = p.pyramid.model_copy(update={"cells": CellModelParams()})  # the plain cell model: no hit guard
    maps = TiledPyramid(particles, pyramid, p.tile, size=8.0, centre=tuple(truth[0, :2]))
    for i in range(0, k, 3):
        r, a = scans.beams(i)
        hit = r < scans.max_range
        maps.integrate(compose(truth[i : i + 1], scans.mount), np.where(hit, r, np.minimum(r, 5.0)), a, hit, which=[0])
    maps.resample(np.zeros(particles, np.int64))
    r, a = scans.beams(k)
    hit = r < scans.max_range
    pts = transform_points(scans.mount, np.column_stack([r[hit] * np.cos(a[hit]), r[hit] * np.sin(a[hit])]))
    return maps, pts, truth[k : k + 1] + np.array([0.05, -0.03, 0.02]), np.diag([0.15**2, 0.15**2, 0.13**2])


def _literal_ssr(grid: OccupancyGrid, pts, X):
    """Σ_n (1 − M(R(ψ) s_n + t))² (K,) at poses X (K, 3), M the bilinear interpolation of σ(log-odds) between the
    cell centres of ``grid`` (the prior outside it), written out in numpy."""
    c, s = np.cos(X[:, 2:]), np.sin(X[:, 2:])
    wx = X[:, :1] + c * pts[:, 0] - s * pts[:, 1]
    wy = X[:, 1:2] + s * pts[:, 0] + c * pts[:, 1]
    res = grid.params.resolution
    gx, gy = (wx - grid.origin[0]) / res - 0.5, (wy - grid.origin[1]) / res - 0.5
    x0, y0 = np.floor(gx).astype(int), np.floor(gy).astype(int)
    fx, fy = gx - x0, gy - y0
    prob = 1.0 / (1.0 + np.exp(-grid.log_odds.astype(float)))
    h, w = prob.shape

    def m(x, y):
        inside = (x >= 0) & (y >= 0) & (x < w) & (y < h)
        return np.where(inside, prob[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)], 1.0 / (1.0 + np.exp(-grid.l0)))

    M = (1 - fy) * ((1 - fx) * m(x0, y0) + fx * m(x0 + 1, y0)) + fy * (
        (1 - fx) * m(x0, y0 + 1) + fx * m(x0 + 1, y0 + 1)
    )
    return np.sum((1.0 - M) ** 2, axis=1)


def _brute_force_target(grid, pts, guess, motion_cov, sigma, centre, half, n=41):
    """The target τ(ξ) = exp(−Σ r²/2σ_z²) N(ξ; ĝ, Σ_u) on an n³ lattice of ±half (3,) around ``centre`` (3,):
    its mean (3,), covariance (3, 3), log of its integral (Riemann sum) and the share of its mass on the
    lattice's faces (small: the box holds the target)."""
    axes = [np.linspace(-h, h, n) for h in half]
    D = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    X = centre + D
    ssr = np.concatenate([_literal_ssr(grid, pts, X[i : i + 8192]) for i in range(0, len(X), 8192)])
    e = X - guess
    e[:, 2] = (e[:, 2] + np.pi) % (2 * np.pi) - np.pi
    log_tau = (
        -0.5 * ssr / sigma**2
        - 0.5 * np.einsum("ki,ij,kj->k", e, np.linalg.inv(motion_cov), e)
        - 0.5 * np.log(np.linalg.det(2 * np.pi * motion_cov))
    )
    tau = np.exp(log_tau - log_tau.max())
    w = tau / tau.sum()
    mean = w @ D
    cov = np.einsum("k,ki,kj->ij", w, D - mean, D - mean)
    face = np.any(np.abs(D) >= np.asarray(half) - 1e-12, axis=1)
    log_eta = log_tau.max() + np.log(tau.sum() * np.prod([a[1] - a[0] for a in axes]))
    return centre + mean, cov, log_eta, w[face].sum()


def _proposal_and_brute_force(sigma, half):
    from slamarena.mapping.rbpf.proposal import gauss_newton, quadrature

    maps, pts, guess, motion_cov = _target_state()
    p = RBPF.Params()
    modes, _ = gauss_newton(
        maps,
        pts,
        guess,
        np.linalg.inv(motion_cov),
        sigma,
        p.iterations,
        p.tol_translation,
        p.tol_rotation,
        p.max_step_translation,
        p.max_step_rotation,
        halvings=p.step_halvings,
    )
    mu, cov, log_eta, _ = quadrature(maps, pts, modes, guess, motion_cov, sigma)
    brute = _brute_force_target(maps.finest.dense(0), pts, guess[0], motion_cov, sigma, modes[0], half)
    return (mu[0], cov[0], log_eta[0]), brute


def test_scan_likelihood_kernel_equals_the_literal_sum():
    """The proposal's numba Σ r² over the tiled map equals the literal numpy sum on the particle's dense grid."""
    from slamarena.mapping.rbpf.proposal import residuals

    maps, pts, guess, _ = _target_state()
    X = guess + np.random.default_rng(0).normal(0.0, [0.2, 0.2, 0.1], (50, 3))
    ssr, _, _ = residuals(maps, pts, X[None])
    np.testing.assert_allclose(ssr[0], _literal_ssr(maps.finest.dense(0), pts, X), rtol=1e-5, atol=1e-5)


def test_proposal_is_the_brute_force_target_where_the_likelihood_is_sharp():
    """σ_z = 0.25 (about the residuals' own spread): the target is one Gaussian-like peak, and the 27-point fit
    gives its mean, standard deviations and integral (target on a 41³ lattice of ±(8 cm, 3 cm, 20 mrad) around
    the mode): mean within 2 mm / 0.5 mrad, standard deviations within 30 %, log η within 0.3. (The 27 points sit at
    ±√3 Laplace σ of the converged mode, on a kink of the bilinear map where the curvature is above the peak's
    average: standard deviations 0.72–0.80 of the target's, log η +0.22; research/method/rbpf.md)"""
    (mu, cov, log_eta), (mean, bcov, blog_eta, face) = _proposal_and_brute_force(0.25, (0.08, 0.03, 0.02))
    assert face < 1e-3
    d = mu - mean
    d[2] = (d[2] + np.pi) % (2 * np.pi) - np.pi
    assert np.all(np.abs(d) < [2e-3, 2e-3, 5e-4]), d
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), np.sqrt(np.diag(bcov)), rtol=0.3)
    assert abs(log_eta - blog_eta) < 0.3, (log_eta, blog_eta)


@pytest.mark.xfail(
    strict=True,
    reason="research/notebook/2026-11-23-rbpf-proposal-vs-target.md 'Is the proposal the target?': at the shipped σ_z = 1 the "
    "target is a narrow peak on a wide base; the 27 points, placed by the peak's curvature, give a heading "
    "standard deviation 4–5× smaller than the target's and log η 1.4–1.5 too small",
)
def test_proposal_is_the_brute_force_target_at_the_shipped_likelihood():
    """The same check at the shipped σ_z = 1 (target on a 41³ lattice of ±(0.8 m, 0.7 m, 0.6 rad)): standard
    deviations within 30 %, log η within 0.3."""
    (mu, cov, log_eta), (mean, bcov, blog_eta, face) = _proposal_and_brute_force(
        RBPF.Params().sigma_likelihood, (0.8, 0.7, 0.6)
    )
    assert face < 1e-3
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), np.sqrt(np.diag(bcov)), rtol=0.3)
    assert abs(log_eta - blog_eta) < 0.3, (log_eta, blog_eta)


def test_mode_proposal_draws_narrowly_and_weights_by_the_target():
    """``proposal="mode"`` on the state above at the shipped σ_z = 1, 400 particles sharing one map and one guess.
    Each pose is the optimum of p(z | m, ξ) N(ξ; x, Σ_u) from the mode ξ* of the target, x ~ N(ĝ, Σ_u); for a
    Gaussian target that is ξ* + A⁻¹Λ(x − ĝ) ~ N(ξ*, A⁻¹ΛA⁻¹) (research/method/rbpf_mode_proposal.md "The mode proposal").
    The poses spread less than half as much as the Gaussian proposal's draws N(μ, Σ) in every direction (lateral 1.8
    against 23 mm, heading 1.1 against 17 mrad; the draw x itself: 150 mm, 130 mrad), yet along the track, where the
    scan pins least, at least as much as A⁻¹ΛA⁻¹ (the draw's offset is there: the optimum alone would not). Across
    the track and in heading they spread less than A⁻¹ΛA⁻¹: the converged optimum lies on a kink of the bilinear map,
    which absorbs small offsets of x (the optimum of a kink plus a quadratic is a soft threshold). Every particle's
    log η is the target's, the Gaussian proposal's 27-point one at ξ* (within 0.2)."""
    from slamarena.mapping.rbpf.proposal import gauss_newton, quadrature, residuals

    P = 400
    maps, pts, guess, motion_cov = _target_state(particles=P)
    f = RBPF(particles=P, proposal="mode")
    f.maps, p, info = maps, f.params, np.linalg.inv(motion_cov)
    poses, fallbacks, log_eta, _ = f._propose(pts, np.repeat(guess, P, axis=0), motion_cov, np.random.default_rng(1))
    modes, _ = gauss_newton(
        maps,
        pts,
        guess,
        info,
        p.sigma_likelihood,
        p.iterations,
        p.tol_translation,
        p.tol_rotation,
        p.max_step_translation,
        p.max_step_rotation,
        halvings=p.step_halvings,
    )
    _, cov, target_log_eta, _ = quadrature(maps, pts, modes, guess, motion_cov, p.sigma_likelihood)
    _, H, _ = residuals(maps, pts, modes[:, None, :])
    A_inv = np.linalg.inv(H[0] / p.sigma_likelihood**2 + info)
    d = poses - modes
    d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    sd, gaussian_sd = d.std(axis=0), np.sqrt(np.diag(cov[0]))
    assert fallbacks == 0
    assert np.all(sd < 0.5 * gaussian_sd), (sd, gaussian_sd)
    assert sd[0] >= np.sqrt((A_inv @ info @ A_inv)[0, 0]), sd
    np.testing.assert_allclose(log_eta, target_log_eta[0], atol=0.2)


def test_fresh_odometry_readings():
    odom = np.array([[0, 0, 0], [0.1, 0, 0], [0.1, 0, 0], [0.1, 0, 0], [np.nan, 0, 0], [0.5, 0, 0], [0.5, 0, 0.1]])
    assert fresh_readings(odom).tolist() == [True, True, False, False, False, True, True]


def _frozen(seq, first, n):
    """The odometry of scans first … first + n − 1 repeats the reading of scan first − 1 (mit-csail's fault)."""
    pose = seq.scans.pose.copy()
    pose[first : first + n] = pose[first - 1]
    return dataclasses.replace(seq, scans=dataclasses.replace(seq.scans, pose=pose))


def test_a_frozen_odometry_stretch_moves_the_pose_once():
    """Odometry frozen for four scans, then its jump: the pose after the jump is where the jump puts it,
    not that motion added on top of the poses the filter tracked meanwhile (which would add the 4 × 0.14 m the
    robot drove): after the jump the error is within 1 cm of the same filter's on the unfrozen odometry."""
    seq = make_sequence(n=60, odo_sigma=(0.0, 0.0, 0.0))
    truth = seq.ground_truth.poses
    err = [np.hypot(*(RBPF(particles=3).run(s).poses[:, :2] - truth[:, :2]).T) for s in (seq, _frozen(seq, 30, 4))]
    assert err[1][34:].max() < min(err[0][34:].max() + 0.01, 0.1), (err[0][30:40], err[1][30:40])


def test_filter_reports_resampling_neff_and_memory(room_sequence):
    P = 8
    est = RBPF(particles=P, resample_threshold=1.0).run(room_sequence)
    d = est.diagnostics
    steps = d["filter_step"]
    assert est.meta["filter_steps"] == steps.sum() > 5
    # N_eff < P · threshold at a step ⇔ it resampled (threshold 1: every step whose weights are not all equal)
    # one N_eff per weighted filter step (all but the first), at that step's scan stamp
    assert d["neff"].size == d["neff_t"].size == d["resampled"].size == steps.sum() - 1
    np.testing.assert_array_equal(d["neff_t"], room_sequence.scans.t[steps][1:])
    assert np.array_equal(d["resampled"], d["neff"] < P) and np.all((d["neff"] >= 1 - 1e-9) & (d["neff"] <= P + 1e-9))
    assert est.meta["resampling_events"] == d["resampled"].sum() > 0
    assert (
        np.all(d["memory_per_particle"][steps] > 0)
        and est.meta["memory_per_particle"] < est.meta["memory_unshared_per_particle"]
    )
    never = RBPF(particles=P, resample_threshold=1e-9).run(room_sequence)
    assert never.meta["resampling_events"] == 0


def test_weight_tempering_flattens_the_weights_only(room_sequence):
    """γ multiplies the log-weights and nothing else: without resampling the draws, the lineages and the best
    particle (chosen by the untempered Σ log η) are the same for every γ, and N_eff is larger with γ < 1 (with
    log w = γ Σ log η, N_eff rises monotonically to P as γ falls to 0)."""
    runs = [RBPF(particles=8, resample_threshold=1e-9, weight_tempering=g).run(room_sequence) for g in (1.0, 1 / 3)]
    full, flat = runs
    assert full.meta["resampling_events"] == flat.meta["resampling_events"] == 0
    assert np.array_equal(full.poses, flat.poses) and full.meta["best_particle"] == flat.meta["best_particle"]
    assert np.all(flat.diagnostics["neff"] >= full.diagnostics["neff"] - 1e-9)
    assert np.any(flat.diagnostics["neff"] > full.diagnostics["neff"] + 1e-3)


def test_room_drive_is_seeded_and_beats_odometry(room_sequence):
    from slamarena.datasets.estimate import Estimate
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate

    slam = RBPF(particles=6, seed=3)
    with pytest.raises(ValueError, match="run"):
        slam.trajectory(0)
    a = slam.run(room_sequence)
    assert np.array_equal(slam.trajectory(a.meta["best_particle"]), a.poses)  # every lineage, the best one the estimate
    assert all(slam.trajectory(i).shape == a.poses.shape and np.all(np.isfinite(slam.trajectory(i))) for i in range(6))
    assert (
        list(slam.map.shape) == a.meta["map_shape"] and slam.map is slam.map
    )  # the best particle's finest grid, one copy
    assert np.array_equal(slam.map.log_odds, slam.maps.finest.dense(a.meta["best_particle"]).log_odds)
    b = RBPF(particles=6, seed=3).run(room_sequence)
    c = RBPF(particles=6, seed=4).run(room_sequence)
    assert np.array_equal(a.poses, b.poses) and not np.array_equal(a.poses, c.poses)
    odometry = Estimate("odometry", room_sequence.scans.t, room_sequence.scans.pose)
    A = lambda e: ate(e, reference_of(room_sequence), ATEParams())[0]["rmse"]
    assert A(a) < 0.02 < 0.05 < A(odometry)
    assert a.t.shape == room_sequence.scans.t.shape and a.step_time.shape == a.t.shape


def test_bad_beams_are_counted_and_a_sequence_without_odometry_is_refused(room_sequence):
    ranges = room_sequence.scans.ranges.copy()
    ranges[5, :20] = np.nan
    ranges[6, :] = -1.0
    seq = dataclasses.replace(room_sequence, scans=dataclasses.replace(room_sequence.scans, ranges=ranges))
    est = RBPF(particles=2).run(seq)
    assert est.meta["bad_beams"] == 20 + ranges.shape[1] and est.meta["scans_all_bad"] == 1
    assert not est.diagnostics["matched"][6] and np.all(np.isfinite(est.poses))
    blind = dataclasses.replace(room_sequence, scans=dataclasses.replace(room_sequence.scans, pose=None))
    with pytest.raises(ValueError, match="odometry"):
        RBPF().run(blind)


def test_parameters_bad_values_unknown_keys_and_the_model_form():
    for bad in ({"particles": 0}, {"resample_threshold": 1.5}, {"weight_tempering": 0.0}, {"sigma_likelihood": -1.0}):
        with pytest.raises(ValidationError, match=next(iter(bad))):
            RBPF(**bad)
    with pytest.raises(ValidationError, match="particels: not a parameter of RBPFParams; did you mean particles?"):
        RBPF(particels=30)
    with pytest.raises(
        ValidationError, match="sigma_t_min: not a parameter of RBPFParams; did you mean motion.sigma_t_min?"
    ):
        RBPF(sigma_t_min=0.2)
    assert RBPF(RBPF.Params(particles=7)).params == RBPF(particles=7).params


def test_a_partial_section_keeps_the_methods_other_defaults_in_it():
    """``pyramid: {resolution: 0.1}`` changes the resolution and keeps the RBPF's own cell model (hit guard 1, where
    the cell model's default is 0); ``motion`` likewise keeps the other five noise terms."""
    p = RBPF(pyramid={"resolution": 0.1}, motion={"sigma_r_min": 0.2}).params
    assert p.pyramid.resolution == 0.1 and p.pyramid.cells.hit_guard == 1 and CellModelParams().hit_guard == 0
    assert p.motion == RBPF.Params().motion.model_copy(update={"sigma_r_min": 0.2})
    assert RBPF(pyramid={"cells": {"p_hit": 0.8}}).params.pyramid.cells.hit_guard == 1


def test_rbpf_is_a_registered_method_taking_particles_and_seed():
    from slamarena.experiments.config import method_table
    from slamarena.mapping import REGISTRY
    from slamarena.params import params_model
    from slamarena.targets import import_target

    assert import_target(REGISTRY["rbpf"]) is RBPF and "rbpf" in method_table()
    fields = params_model(RBPF).model_fields
    assert "particles" in fields and "seed" in fields


def test_sim_loop_with_30_particles_maps_as_well_as_grid_slam():
    """One lap of the loop world (181 beams, 12 m, 2.5 Hz): the best particle's ATE is within 1.5× GridSLAM's
    (about 3 cm both) — the filter does not break a loop that scan matching already closes."""
    from slamarena.datasets.sim.laser import simulate
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate
    from slamarena.mapping.grid_slam import GridSLAM

    seq = simulate(n_beams=181, scan_rate=2.5)
    est = RBPF(particles=30).run(seq)
    rbpf, grid = (ate(e, reference_of(seq), ATEParams())[0]["rmse"] for e in (est, GridSLAM().run(seq)))
    assert rbpf < 0.05 and rbpf < 1.5 * grid, (rbpf, grid)
    assert est.meta["resampling_events"] > 0 and est.meta["proposal_fallbacks"] == 0


LONG_LOOP = {
    "world": "long_loop",
    "max_range": 4.0,
    "n_beams": 91,
    "sigma_range": 0.02,
    "k_r": 0.06,
    "k_rt": 0.03,
    "k_t": 0.085,
    "scan_rate": 2.5,
    "laps": 2,
}


def _closure(seed: int) -> tuple[tuple[float, float], tuple[float, float]]:
    """(loop-relation error, ATE) of the best of 30 particles (filter seed 0, defaults) and of GridSLAM on the
    ``long_loop`` drive of world seed ``seed``. The loop relations pair each place of the first lap with the same
    place on the second, from the ground truth: their error is small only where the map is
    consistent where the path meets itself, i.e. where the loop is closed (the ``loop`` metric)."""
    from slamarena.datasets.sim.laser import simulate
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.relations import loop_relation_error
    from slamarena.experiments.metrics.trajectory import ATEParams, ate
    from slamarena.mapping.grid_slam import GridSLAM

    seq = simulate(**LONG_LOOP, seed=seed)
    ref = reference_of(seq)
    score = lambda e: (loop_relation_error(e, ref)[0]["trans_mean"], ate(e, ref, ATEParams())[0]["rmse"])
    return score(RBPF(particles=30, seed=0).run(seq)), score(GridSLAM().run(seq))


def test_sim_loop_closed_implicitly_by_the_best_particle():
    """The issue's test, on a loop with metres to close: two laps of ``long_loop`` (a 165 m corridor loop, 4 m laser,
    odometry erring by 6 cm along the track per 0.5 m filter step; chosen by a rule on GridSLAM alone,
    research/notebook/2026-11-23-rbpf-loop-rounds-1-3.md "A loop with something to close"). GridSLAM, which closes no
    loop, ends the first lap off
    and maps the second lap beside it; the best of 30 particles selects a lineage that meets its own first lap:
    its loop-relation error is a fraction of GridSLAM's, and its ATE is below GridSLAM's (world seed 0: 1.12
    against 1.27 m)."""
    (rbpf_loop, rbpf_ate), (grid_loop, grid_ate) = _closure(0)
    assert rbpf_loop < 0.5 * grid_loop and rbpf_ate < grid_ate, (rbpf_loop, rbpf_ate, grid_loop, grid_ate)


@pytest.mark.slow
def test_sim_loop_closed_implicitly_over_five_seeds():
    """The pre-registered rule (research/notebook/2026-11-23-rbpf-loop-rounds-4-6.md, round 6: met on fresh world seeds
    40–59, 18 of 20) on world
    seeds 0–4: the best of 30 particles' loop-relation error below GridSLAM's on at least 4 of the 5 drives, and its
    median below GridSLAM's median."""
    runs = [_closure(seed) for seed in range(5)]
    rbpf, grid = np.array([r[0][0] for r in runs]), np.array([r[1][0] for r in runs])
    assert np.sum(rbpf < grid) >= 4 and np.median(rbpf) < np.median(grid), (rbpf, grid)


@pytest.mark.parametrize("halvings", [0, 4])
def test_step_halving_makes_the_proposals_gauss_newton_a_descent_that_converges(halvings):
    """With ``step_halvings`` a step that does not lower −log τ is halved, so the mode search is a descent: restarted at
    its own result it stays there (tolerances 10⁻⁶), and −log τ never rises. Without it the bilinear map's kinks make the
    undamped step cycle by millimetres (research/method/rbpf_mode_proposal.md "The mode proposal"), which the case 0 asserts."""
    from slamarena.mapping.rbpf.proposal import gauss_newton, residuals

    maps, pts, guess, motion_cov = _target_state()
    p, info = RBPF.Params(), np.linalg.inv(motion_cov)
    gn = dict(
        sigma=p.sigma_likelihood,
        iterations=100,
        tol_t=1e-6,
        tol_r=1e-6,
        max_step_t=p.max_step_translation,
        max_step_r=p.max_step_rotation,
        halvings=halvings,
    )

    def cost(x):
        e = guess[0] - x
        e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi
        return 0.5 * residuals(maps, pts, x[None, None, :])[0][0, 0] / p.sigma_likelihood**2 + 0.5 * e @ info @ e

    mode, _ = gauss_newton(maps, pts, guess, info, **gn)
    again, _ = gauss_newton(maps, pts, guess, info, start=mode, finest_only=True, **gn)
    moved = np.abs(again[0] - mode[0])
    if halvings == 0:
        assert moved.max() > 1e-3, moved  # the two-cycle the halving removes
    else:
        assert (
            moved.max() < 1e-5 and cost(again[0]) <= cost(mode[0]) + 1e-9 and cost(mode[0]) < cost(guess[0].copy())
        ), moved
