"""Dead reckoning: exact on noise-free input, covariance against a Monte Carlo spread."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Increments, Noise, Sequence, Trajectory, Twist
from slamarena.estimators.dead_reckoning import DeadReckoning
from slamarena.estimators.models import ARC, EULER, compose_jacobians, propagate_covariance


def _controls(K=200, dt=0.1, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(K) * dt
    v = 1.0 + 0.3 * np.sin(0.05 * np.arange(K))
    omega = 0.4 * np.cos(0.03 * np.arange(K)) + 0.01 * rng.standard_normal(K)
    return t, v, omega, np.full(K, dt)


def _literal_truth(model, start, v, omega, dt):
    poses = [np.asarray(start, float)]
    for k in range(len(v)):
        poses.append(model.predict(poses[-1], v[k], omega[k], dt[k]))
    return np.array(poses)


@pytest.mark.parametrize("name,model", [("arc", ARC), ("euler", EULER)])
def test_exact_on_noise_free_twist(name, model):
    t, v, omega, dt = _controls()
    start = np.array([1.0, -2.0, 0.3])
    seq = Sequence("toy", motion=Twist(t=t, v=v, omega=omega, dt=dt), initial_pose=start)
    est = DeadReckoning(motion_model=name).run(seq)
    truth = _literal_truth(model, start, v, omega, dt)
    np.testing.assert_allclose(est.t, np.append(t, t[-1] + dt[-1]))
    np.testing.assert_allclose(est.poses[:, :2], truth[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(est.poses[:, 2] - truth[:, 2]), 0, atol=1e-9)
    assert est.pose_cov is None  # no stated noise → no covariance


def test_gaps_are_standing_still_and_overlaps_follow_stepping():
    # rows hold for 0.05 s of each 0.1 s period: the robot stands still in between
    t = np.arange(10) * 0.1
    seq = Sequence("gaps", motion=Twist(t=t, v=np.ones(10), omega=np.zeros(10), dt=np.full(10, 0.05)))
    est = DeadReckoning().run(seq)
    np.testing.assert_allclose(est.poses[:, 0], np.r_[0, 0.05 * np.arange(1, 11)])
    # overlapping rows (each holds 0.2 s but the next starts after 0.1 s): the replay walks
    # the stamps with twist_pieces, as filters do
    seq = Sequence("overlap", motion=Twist(t=t, v=np.ones(10), omega=np.zeros(10), dt=np.full(10, 0.2)))
    est = DeadReckoning().run(seq)
    from slamarena.estimators.stepping import twist_pieces

    expected = [0.0]
    ends = np.append(t[1:], t[-1] + 0.2)
    for a, b in zip(t, ends):
        v, w, d = twist_pieces(seq.motion, a, b)
        expected.append(expected[-1] + float(np.sum(v * d)))
    np.testing.assert_allclose(est.poses[:, 0], expected)


def test_nonfinite_rows_are_rejected_and_counted():
    t, v, omega, dt = _controls(K=20)
    v = v.copy()
    v[5] = np.nan
    est = DeadReckoning().run(Sequence("nan", motion=Twist(t=t, v=v, omega=omega, dt=dt)))
    assert np.all(np.isfinite(est.poses))
    assert est.meta["rejected_motion_rows"] == 1
    np.testing.assert_allclose(est.poses[6], est.poses[5])  # row 5 stands still


def test_increments_exact():
    rng = np.random.default_rng(3)
    delta = np.column_stack([rng.uniform(0, 0.5, 50), rng.normal(0, 0.05, 50), rng.normal(0, 0.1, 50)])
    start = np.array([0.5, 0.5, -1.0])
    seq = Sequence("inc", motion=Increments(t=np.arange(50.0), delta=delta), initial_pose=start)
    est = DeadReckoning().run(seq)
    pose = start
    for k in range(50):
        pose = compose(pose, delta[k])
        np.testing.assert_allclose(est.poses[k], pose, atol=1e-12)


def test_prefix_sum_covariance_equals_literal_recursion():
    rng = np.random.default_rng(7)
    K = 300
    poses = np.column_stack([rng.normal(size=K), rng.normal(size=K), rng.uniform(-np.pi, np.pi, K)])
    delta = rng.normal(0, 0.3, (K, 3))
    G, _ = compose_jacobians(poses, delta)
    L = rng.normal(size=(K, 3, 3))
    M = L @ np.swapaxes(L, 1, 2) * 1e-3
    A = rng.normal(size=(3, 3))
    P0 = A @ A.T
    P = propagate_covariance(P0, G, M)
    literal = [P0]
    for k in range(K):
        literal.append(G[k] @ literal[-1] @ G[k].T + M[k])
    np.testing.assert_allclose(P, np.array(literal), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", ["arc", "euler"])
def test_twist_covariance_matches_monte_carlo(name):
    """Noisy controls ũ = u + ε, ε ~ N(0, Q): the spread of the final pose matches P_K."""
    t, v, omega, dt = _controls(K=100)
    Q = np.diag([0.05**2, 0.03**2])
    rng = np.random.default_rng(11)
    runs = 2000
    eps = rng.multivariate_normal(np.zeros(2), Q, size=(runs, len(t)))
    model = ARC if name == "arc" else EULER
    finals = np.array([model.integrate(np.zeros(3), v + e[:, 0], omega + e[:, 1], dt)[-1] for e in eps])
    seq = Sequence("mc", motion=Twist(t=t, v=v, omega=omega, dt=dt), noise=Noise(twist_cov=Q))
    est = DeadReckoning(motion_model=name).run(seq)
    mean = est.poses[-1]
    err = finals - mean
    err[:, 2] = wrap_angle(err[:, 2])
    spread = err.T @ err / runs
    P = est.pose_cov[-1]
    # linearisation is good at this noise level; 2000 runs give ≈ 3 % sampling error on variances
    np.testing.assert_allclose(np.diag(spread), np.diag(P), rtol=0.1)
    corr = lambda C: C[0, 1] / np.sqrt(C[0, 0] * C[1, 1])  # noqa: E731
    assert abs(corr(spread) - corr(P)) < 0.05
    # and the error is consistent: mean NEES of the final pose ≈ 3
    nees = np.einsum("ni,ij,nj->n", err, np.linalg.inv(P), err)
    assert 2.8 < nees.mean() < 3.2


def test_increment_covariance_uses_stream_or_stated_noise():
    rng = np.random.default_rng(5)
    K = 80
    delta = np.column_stack([np.full(K, 0.2), np.zeros(K), np.full(K, 0.05)])
    C = np.diag([0.01**2, 0.005**2, 0.01**2])
    seq = Sequence("inc", motion=Increments(t=np.arange(K, dtype=float), delta=delta), noise=Noise(increment_cov=C))
    est = DeadReckoning().run(seq)
    runs = 2000
    noisy = delta + rng.multivariate_normal(np.zeros(3), C, size=(runs, K))
    from slamarena.datasets.geometry import accumulate

    finals = np.array([accumulate(np.zeros(3), d)[-1] for d in noisy])
    err = finals - est.poses[-1]
    err[:, 2] = wrap_angle(err[:, 2])
    np.testing.assert_allclose(np.diag(err.T @ err / runs), np.diag(est.pose_cov[-1]), rtol=0.1)
    # a per-row covariance in the stream takes precedence over the stated noise
    seq2 = Sequence(
        "inc2",
        motion=Increments(t=np.arange(K, dtype=float), delta=delta, cov=np.broadcast_to(4 * C, (K, 3, 3))),
        noise=Noise(increment_cov=C),
    )
    np.testing.assert_allclose(DeadReckoning().run(seq2).pose_cov[-1], 4 * est.pose_cov[-1], rtol=1e-9)


def test_bad_parameters_rejected():
    with pytest.raises(ValueError, match="motion_model"):
        DeadReckoning(motion_model="rk4")
    with pytest.raises(ValueError, match="initial_sigma"):
        DeadReckoning(initial_sigma=[1.0, -1.0, 0.0])
    with pytest.raises(ValueError, match="propagate_cov"):
        DeadReckoning(propagate_cov=False)  # a misspelt parameter is an error, never ignored
    with pytest.raises(ValueError, match="motion input"):
        DeadReckoning().run(Sequence("empty", ground_truth=Trajectory(t=[0.0], poses=[[0, 0, 0]])))
