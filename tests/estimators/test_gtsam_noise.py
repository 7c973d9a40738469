"""Noise mapping and frame conventions of the GTSAM smoothers (checked against GTSAM and Monte Carlo)."""

from __future__ import annotations

import numpy as np
import pytest

gtsam = pytest.importorskip("gtsam")

from checks import assert_covariances_close  # noqa: E402

from slamarena.datasets.geometry import compose, wrap_angle  # noqa: E402
from slamarena.datasets.sequence import Twist  # noqa: E402
from slamarena.estimators.gtsam_smoother.graph import X, observation_noise, remaining_decrease  # noqa: E402
from slamarena.estimators.gtsam_smoother.noise import (  # noqa: E402
    body_to_world,
    floor_to_uncertainty,
    increments_relative,
    regularise,
    twist_relative,
    twist_relatives,
    world_to_body,
)
from slamarena.estimators.gtsam_smoother.problem import twist_pieces_of_intervals  # noqa: E402
from slamarena.estimators.models import ARC, EULER  # noqa: E402
from slamarena.estimators.stepping import twist_pieces  # noqa: E402


def _pose(p) -> np.ndarray:
    return np.array([p.x(), p.y(), p.theta()])


def test_marginal_covariance_is_body_frame_constructed_case():
    """A pose facing +y (θ = π/2) that is uncertain along its own x axis is uncertain along world y."""
    Sigma_body = np.diag([4.0, 0.01, 1e-4])
    graph = gtsam.NonlinearFactorGraph()
    graph.add(
        gtsam.PriorFactorPose2(X(0), gtsam.Pose2(1.0, 2.0, np.pi / 2), gtsam.noiseModel.Gaussian.Covariance(Sigma_body))
    )
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose2(1.0, 2.0, np.pi / 2))
    marginal = gtsam.Marginals(graph, values).marginalCovariance(X(0))
    assert_covariances_close(marginal, Sigma_body, rtol=1e-9)  # GTSAM reports the body frame
    world = body_to_world(np.pi / 2, marginal)
    assert_covariances_close(world, np.diag([0.01, 4.0, 1e-4]), rtol=1e-9)
    assert_covariances_close(world_to_body(np.pi / 2, world), marginal, rtol=1e-9)


def test_body_to_world_matches_monte_carlo_of_gtsam_retraction(rng):
    """Samples x̂ · Exp(ξ), ξ ~ N(0, Σ_body): their world-frame (x, y, θ) covariance is J Σ Jᵀ."""
    x_hat = gtsam.Pose2(3.0, -1.0, 2.2)
    A = rng.normal(size=(3, 3))
    Sigma = 1e-3 * (A @ A.T + np.eye(3))
    xi = rng.multivariate_normal(np.zeros(3), Sigma, size=20000)
    samples = np.array([_pose(x_hat.compose(gtsam.Pose2.Expmap(d))) for d in xi])
    e = samples - _pose(x_hat)
    e[:, 2] = wrap_angle(e[:, 2])
    empirical = np.cov(e.T)
    predicted = body_to_world(2.2, Sigma)
    np.testing.assert_allclose(empirical, predicted, atol=0.05 * np.abs(predicted).max())
    wrong = body_to_world(-2.2, Sigma)  # the transposed rotation: must be distinguishable
    assert np.abs(empirical - wrong).max() > 5 * np.abs(empirical - predicted).max()


@pytest.mark.parametrize("model", [EULER, ARC], ids=["euler", "arc"])
def test_twist_relative_covariance_is_the_between_factor_error_covariance(model, rng):
    """Monte Carlo of the control noise: (1) the relative pose's additive covariance is the filters'
    propagation; (2) GTSAM's BetweenFactorPose2 error of the samples has covariance Jᵀ P J."""
    v = np.array([1.0, 1.2, 0.8, 1.1])
    w = np.array([0.3, -0.2, 0.5, 0.4])
    dt = np.array([0.1, 0.1, 0.05, 0.1])
    M = np.diag([0.05**2, 0.1**2])
    delta, P = twist_relative(model, v, w, dt, M)
    N = 20000
    noisy_v = v + rng.normal(0, 0.05, size=(N, v.size))
    noisy_w = w + rng.normal(0, 0.1, size=(N, w.size))
    rel = np.zeros((N, 3))
    for k in range(v.size):
        rel = model.predict(rel, noisy_v[:, k], noisy_w[:, k], dt[k])
    e = rel - delta
    e[:, 2] = wrap_angle(e[:, 2])
    np.testing.assert_allclose(np.cov(e.T), P, atol=0.05 * np.abs(P).max())
    factor = gtsam.BetweenFactorPose2(X(0), X(1), gtsam.Pose2(*delta), gtsam.noiseModel.Unit.Create(3))
    errors = []
    for r in rel[:5000]:
        values = gtsam.Values()
        values.insert(X(0), gtsam.Pose2())
        values.insert(X(1), gtsam.Pose2(*r))
        errors.append(factor.unwhitenedError(values))
    body = world_to_body(delta[2], P)
    np.testing.assert_allclose(np.cov(np.array(errors).T), body, atol=0.07 * np.abs(body).max())


def test_increments_relative_matches_monte_carlo(rng):
    deltas = np.array([[0.5, 0.02, 0.1], [0.4, -0.01, 0.3], [0.6, 0.0, -0.2]])
    C = np.diag([0.02**2, 0.01**2, 0.02**2])
    covs = np.broadcast_to(C, (3, 3, 3))
    delta, P = increments_relative(deltas, covs)
    np.testing.assert_allclose(delta, compose(compose(deltas[0], deltas[1]), deltas[2]), atol=1e-12)
    rel = np.zeros((20000, 3))
    for d in deltas:
        rel = compose(rel, d + rng.multivariate_normal(np.zeros(3), C, size=20000))
    e = rel - delta
    e[:, 2] = wrap_angle(e[:, 2])
    np.testing.assert_allclose(np.cov(e.T), P, atol=0.05 * np.abs(P).max())


def test_observation_noise_is_in_bearing_range_order():
    R = np.diag([0.3**2, 0.02**2])  # (range, bearing)
    np.testing.assert_allclose(observation_noise(R).sigmas(), [0.02, 0.3])


@pytest.mark.parametrize("noise", ["polar", "cartesian"])
def test_each_observation_factor_whitens_with_its_own_covariance(noise):
    """build_problem + landmark_step_factors: every BearingRangeFactor2D's error at perturbed values is ½ νᵀ R_j⁻¹ ν with
    ν = z − h in (range, bearing) and R_j the row's covariance — R (polar), diag(σ², σ²/r_j²) (cartesian, the filters'
    models.observation_covariances)."""
    from slamarena import datasets
    from slamarena.estimators.gtsam_smoother.graph import L, landmark_step_factors, observation_noises
    from slamarena.estimators.gtsam_smoother.problem import LandmarkProblemParams, build_problem
    from slamarena.estimators.models import observe

    seq = datasets.load("sim:landmarks", n_landmarks=12, laps=1, seed=3)
    R = np.diag([0.04, 0.003])
    problem = build_problem(seq, LandmarkProblemParams(range_bearing_cov=R, range_bearing_noise=noise))
    r = problem.obs_range
    expected = (
        np.broadcast_to(R, (r.size, 2, 2))
        if noise == "polar"
        else np.stack([np.diag([0.04, 0.04 / ri**2]) for ri in r])
    )
    np.testing.assert_allclose(problem.obs_cov, expected, rtol=1e-12)
    rng = np.random.default_rng(0)
    noises = observation_noises(problem)
    rows = np.flatnonzero(problem.obs_pose == problem.obs_pose[len(r) // 2])
    k = int(problem.obs_pose[rows[0]])
    graph = landmark_step_factors(problem, k, np.eye(3), problem.cov, noises, slice(rows[0], rows[-1] + 1))
    pose = np.array([1.0, -0.5, 0.3])
    values = gtsam.Values()
    values.insert(X(k), gtsam.Pose2(*pose))
    marks = {}
    for j in map(int, problem.obs_id[rows]):
        if j not in marks:
            marks[j] = pose[:2] + rng.uniform(3.0, 20.0) * np.array(
                [np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)]
            )
            values.insert(L(j), marks[j])
    errors = [graph.at(i).error(values) for i in range(1, graph.size())]  # factor 0: the between factor
    for e, i in zip(errors, rows):
        h = observe(pose, marks[int(problem.obs_id[i])])
        nu = np.array([problem.obs_range[i] - h[0], wrap_angle(problem.obs_bearing[i] - h[1])])
        assert e == pytest.approx(0.5 * nu @ np.linalg.solve(problem.obs_cov[i], nu), rel=1e-9)


def test_regularise_lifts_only_the_null_direction():
    V = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    P = V @ np.diag([0.04, 0.01]) @ V.T  # rank 2: no lateral noise
    Q = regularise(P, 1e-4)
    lam = np.linalg.eigvalsh(Q)
    np.testing.assert_allclose(lam, [4e-6, 0.01, 0.04], rtol=1e-9)
    np.testing.assert_allclose(regularise(P, 0.0), P)


def _two_poses(pose_cov: np.ndarray, delta: np.ndarray, C: np.ndarray, offset=(0.0, 0.0, 0.0)):
    """x_0 ~ N(0, pose_cov), x_1 = x_0 δ ⊕ C: the graph and values (x_0 moved by ``offset``, x_1 = x_0 δ)."""
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(), gtsam.noiseModel.Gaussian.Covariance(pose_cov)))
    graph.add(gtsam.BetweenFactorPose2(X(0), X(1), gtsam.Pose2(*delta), gtsam.noiseModel.Gaussian.Covariance(C)))
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose2(*offset))
    values.insert(X(1), gtsam.Pose2(*offset).compose(gtsam.Pose2(*delta)))
    return graph, values


def _two_pose_cholesky(pose_cov: np.ndarray, delta: np.ndarray, C: np.ndarray) -> bool:
    """Eliminate [x_0, x_1] in one Cholesky clique (iSAM2's root at a step)."""
    graph, values = _two_poses(pose_cov, delta, C)
    ordering = gtsam.Ordering()
    ordering.push_back(X(0))
    ordering.push_back(X(1))
    try:
        graph.linearize(values).eliminateMultifrontal(ordering)
        return True
    except RuntimeError:  # IndeterminantLinearSystemException
        return False


def test_floor_to_uncertainty_keeps_cholesky_determinate():
    """A 0.1 s step (σ_min = 1 % of σ_max = 0.1 mm) of a pose 0.5 m uncertain sideways: GTSAM's Cholesky calls the
    two-pose clique indeterminate (a pivot below 2⁻²⁴ of its diagonal) although it is determined; lifted by the rule it
    is accepted, the lift is small, and a factor that already satisfies the rule is returned unchanged."""
    delta = np.array([0.1, 0.0, 0.005])
    C = regularise(np.diag([1e-4, 0.0, 2.5e-5]), 1e-4)
    pose_cov = np.diag([0.05**2, 0.5**2, 0.02**2])
    assert not _two_pose_cholesky(pose_cov, delta, C)
    lifted = floor_to_uncertainty(C, pose_cov, delta, 2.0**-22)
    assert _two_pose_cholesky(pose_cov, delta, lifted)
    assert np.linalg.eigvalsh(lifted - C)[0] > -1e-18  # only raised
    assert np.sqrt(np.linalg.eigvalsh(lifted)[0]) < 5 * np.sqrt(np.linalg.eigvalsh(C)[0])
    small = np.diag([0.01**2, 0.01**2, 0.005**2])
    assert floor_to_uncertainty(C, small, delta, 2.0**-22) is C


def test_the_remaining_decrease_of_a_stiff_determined_system_is_solved_by_qr():
    """graph.optimize's convergence guard solves the linearisation at the answer; GTSAM's default Cholesky raised
    'indeterminate linear system' on the stiff two-pose graph above (MRCLAM-like 1 ms steps make such graphs), QR solves it:
    the graph fits both factors exactly, so the remaining decrease is the whole error."""
    delta = np.array([0.1, 0.0, 0.005])
    graph, values = _two_poses(
        np.diag([0.05**2, 0.5**2, 0.02**2]), delta, regularise(np.diag([1e-4, 0.0, 2.5e-5]), 1e-4), (0.01, 0.02, 0.0)
    )
    with pytest.raises(RuntimeError, match="Indeterminant|Indeterminate"):
        graph.linearize(values).optimize()
    assert remaining_decrease(graph, values, "two poses") == pytest.approx(graph.error(values), rel=1e-6)


def test_covariances_are_compared_in_their_own_metric():
    """checks.assert_covariances_close bounds the relative error of the variance along every direction. The tolerance it
    replaced (absolute, 1e-6 of the largest entry) fails on a round-off of 1.5e-6 relative (another machine's BLAS did
    that), and passes a variance doubled along a direction whose variance is below 1e-6 of the largest (a well-anchored
    first pose next to metres of drift)."""
    U = np.linalg.qr(np.array([[1.0, 0.3, 0.1], [0.2, 1.0, 0.4], [0.0, 0.5, 1.0]]))[0]
    lam = np.array([4e-3, 1e-3, 1e-9])
    B = U @ np.diag(lam) @ U.T
    old = lambda A: np.testing.assert_allclose(A, B, atol=1e-6 * np.abs(B).max())  # noqa: E731
    roundoff = (1 + 1.5e-6) * B
    with pytest.raises(AssertionError):
        old(roundoff)
    assert_covariances_close(roundoff, B, rtol=1e-3)
    doubled = B + lam[2] * np.outer(U[:, 2], U[:, 2])
    old(doubled)
    with pytest.raises(AssertionError, match="relative difference 1 > 0.001"):
        assert_covariances_close(doubled, B, rtol=1e-3)


def _twist_relative_literal(model, v, w, dt, M):
    """The filters' recursion over one interval's pieces, one piece at a time."""
    delta, P = np.zeros(3), np.zeros((3, 3))
    for vk, wk, dk in zip(v, w, dt):
        G, V = model.jacobians(delta, vk, wk, dk)
        P = G @ P @ G.T + V @ M @ V.T
        delta = model.predict(delta, vk, wk, dk)
    return delta, P


@pytest.mark.parametrize("model", [EULER, ARC], ids=["euler", "arc"])
def test_twist_relatives_are_the_literal_recursion_of_each_interval_bit_for_bit(model, rng):
    n = 40
    group = np.sort(rng.integers(0, n, 150))  # some intervals have no piece, some several
    v, w, dt = rng.normal(1.0, 0.5, group.size), rng.normal(0.0, 0.8, group.size), rng.uniform(0.01, 0.2, group.size)
    M = np.array([[0.01, 0.002], [0.002, 0.0025]])
    delta, P = twist_relatives(model, v, w, dt, group, n, M)
    for s in range(n):
        d, C = _twist_relative_literal(model, v[group == s], w[group == s], dt[group == s], M)
        assert np.array_equal(delta[s], d) and np.array_equal(P[s], C), s
    d, C = twist_relative(model, v[:5], w[:5], dt[:5], M)
    literal = _twist_relative_literal(model, v[:5], w[:5], dt[:5], M)
    assert np.array_equal(d, literal[0]) and np.array_equal(C, literal[1])


def test_twist_pieces_of_intervals_are_twist_pieces_of_each_interval(rng):
    t = np.cumsum(rng.uniform(0.05, 0.3, 60))
    dt = np.where(rng.random(60) < 0.2, 0.02, np.diff(t, append=t[-1] + 0.1))  # some rows end before the next: gaps
    twist = Twist(t=t, v=rng.normal(1, 0.3, 60), omega=rng.normal(0, 0.5, 60), dt=dt)
    key_t = np.unique(np.concatenate([[t[0] - 1.0], rng.uniform(t[0] - 0.5, t[-1] + 0.5, 90), t[10:20], [t[-1] + 1]]))
    v, w, d, interval = twist_pieces_of_intervals(twist, key_t)
    assert np.all(np.diff(interval) >= 0)
    for s, (a, b) in enumerate(zip(key_t[:-1], key_t[1:])):
        expected = twist_pieces(twist, a, b)
        got = (v[interval == s], w[interval == s], d[interval == s])
        assert all(np.array_equal(x, y) for x, y in zip(got, expected)), s


def test_regularise_of_a_stack_is_regularise_of_each_bit_for_bit(rng):
    A = rng.normal(size=(50, 3, 3))
    P = A @ np.swapaxes(A, 1, 2)
    P[:10, :, 2] = P[:10, 2, :] = 0.0  # rank-deficient: lifted
    stacked = regularise(P, 1e-4)
    assert all(np.array_equal(stacked[k], regularise(P[k], 1e-4)) for k in range(50))
