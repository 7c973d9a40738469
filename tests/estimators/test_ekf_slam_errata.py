"""Errata of the EKF-SLAM notes (research/method/ekf_slam_errata_tests.md): each test passes on the corrected form
used by the code and fails on the form printed in the notes."""

from __future__ import annotations

import numpy as np

from slamarena import datasets
from slamarena.datasets.geometry import wrap_angle
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.models import ARC, EULER, inverse_observation_jacobians, inverse_observe, observe

P0 = np.array([[0.04, 0.01, 0.004], [0.01, 0.09, -0.006], [0.004, -0.006, 0.01]])
X0 = np.array([1.0, 2.0, 0.6])


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def test_E1_covariance_propagates_as_G_P_Gt_not_Gt_P_G_nor_F_P_Ft():
    """000: ``PEst = G.T @ PEst @ G``; 004: ``P = F P Fᵀ`` with 000's F = I. Monte Carlo decides."""
    rng = np.random.default_rng(1)
    u, dt = (4.0, 0.5), 0.5
    samples = rng.multivariate_normal(X0, P0, size=200_000)
    moved = EULER.predict(samples, u[0], u[1], dt)
    moved[:, 2] = X0[2] + u[1] * dt + wrap_angle(moved[:, 2] - X0[2] - u[1] * dt)
    mc = np.cov(moved.T)
    G, _ = EULER.jacobians(X0, u[0], u[1], dt)
    ekf = EKFSLAM(motion_model="euler", initial_pose=X0, initial_cov=P0, twist_cov=[0.0, 0.0])
    ekf.predict(u, dt)
    assert _rel(ekf.P, mc) < 0.02
    assert _rel(G @ P0 @ G.T, mc) < 0.02
    assert _rel(G.T @ P0 @ G, mc) > 0.2  # the reference's transposed form
    assert _rel(np.eye(3) @ P0 @ np.eye(3), mc) > 0.2  # F = I: the heading-position coupling lost


def test_E2_observation_noise_is_R_not_the_motion_noise_block_Cx():
    """000 names ``Q_sim or Cx[0:2, 0:2]`` as the observation noise. With the motion-noise block in S the
    NIS leaves the χ² band; with R it sits at its dimension 2."""
    seq = datasets.load("sim:landmarks", n_landmarks=20, seed=7)
    Cx = np.diag([0.5, 0.5, np.radians(30.0)]) ** 2  # the reference implementation's Cx
    good = EKFSLAM().run(seq).diagnostics["nis"]
    bad = EKFSLAM(range_bearing_cov=Cx[0:2, 0:2]).run(seq).diagnostics["nis"]
    half_width = 3.0 * np.sqrt(2 * 2 / good.size)  # 3σ of the mean of χ²₂ samples
    assert abs(good.mean() - 2.0) < half_width
    assert abs(bad.mean() - 2.0) > 10 * half_width


def test_E3_gain_uses_the_predicted_covariance_not_its_inverse():
    """001: ``K = Σ_k^{-1} Hᵀ (H Σ⁻ Hᵀ + R)^{-1}``. The correct K = Σ⁻ Hᵀ S⁻¹ minimises the Joseph-form
    posterior trace and is what the filter applies; Σ⁻¹ gives a different, worse posterior."""
    ekf = EKFSLAM(initial_pose=X0, initial_cov=P0, range_bearing_cov=[0.01, 0.001])
    ekf.update(np.array([[5.0, 0.4, 0]]))
    ekf.predict((1.0, 0.1), 1.0)
    prior, x_prior = ekf.P.copy(), ekf.x.copy()
    z = np.array([4.2, 0.5])
    H = np.zeros((2, 5))
    from slamarena.estimators.models import observation_jacobians

    H[:, :3], H[:, 3:] = observation_jacobians(x_prior[:3], x_prior[3:])
    R = np.diag([0.01, 0.001])
    S = H @ prior @ H.T + R

    def joseph(K):
        A = np.eye(5) - K @ H
        return A @ prior @ A.T + K @ R @ K.T

    K_good = prior @ H.T @ np.linalg.inv(S)
    K_bad = np.linalg.inv(prior) @ H.T @ np.linalg.inv(S)
    ekf.update(np.array([[z[0], z[1], 0]]))
    np.testing.assert_allclose(ekf.P, joseph(K_good), atol=1e-10)
    assert not np.allclose(ekf.P, joseph(K_bad), atol=1e-3)
    assert np.trace(joseph(K_bad)) > np.trace(joseph(K_good)) + 1e-3
    rng = np.random.default_rng(0)
    for _ in range(20):  # K_good is a minimum of the trace
        assert np.trace(joseph(K_good + 1e-3 * rng.normal(size=K_good.shape))) >= np.trace(joseph(K_good))


def _integrate_unicycle(x, v, w, dt, n=20_000):
    h = dt / n
    x = np.array(x, dtype=float)
    for _ in range(n):  # midpoint rule
        th = x[2] + 0.5 * w * h
        x = x + h * np.array([v * np.cos(th), v * np.sin(th), w])
    return x


def test_E4_arc_model_y_row_sign():
    """001 "with rotation": ``y' = y − (Δx/Δθ) cos θ + (Δx/Δθ) cos(θ + Δθ)`` (and labelled b). The ODE says
    ``y' = y + (v/ω) cos θ − (v/ω) cos(θ + ω dt)``; the notes' own linearisation row belongs to the corrected form."""
    x, v, w, dt = np.array([0.5, -1.0, 0.8]), 1.5, 0.9, 1.2
    truth = _integrate_unicycle(x, v, w, dt)
    np.testing.assert_allclose(ARC.predict(x, v, w, dt), truth, atol=1e-8)
    r = v / w
    notes_y = x[1] - r * np.cos(x[2]) + r * np.cos(x[2] + w * dt)
    assert abs(notes_y - truth[1]) > 0.1
    # the notes' A_t entries: ∂x'/∂θ = −r cos θ + r cos(θ+Δθ), ∂y'/∂θ = −r sin θ + r sin(θ+Δθ)
    G, _ = ARC.jacobians(x, v, w, dt)
    np.testing.assert_allclose(G[0, 2], -r * np.cos(x[2]) + r * np.cos(x[2] + w * dt), atol=1e-12)
    np.testing.assert_allclose(G[1, 2], -r * np.sin(x[2]) + r * np.sin(x[2] + w * dt), atol=1e-12)


def test_E5_range_bearing_is_distance_and_relative_angle():
    """001 defines x̄ = distance, ȳ = bearing, then r = √(x̄² + ȳ²), φ = atan2(ȳ, x̄): metres mixed with
    radians. The model must return the distance and the angle relative to the heading."""
    pose, m = np.array([1.0, 1.0, -0.5]), np.array([4.0, 5.0])
    rng_true = np.hypot(3.0, 4.0)
    brg_true = np.arctan2(4.0, 3.0) + 0.5
    np.testing.assert_allclose(observe(pose, m), [rng_true, brg_true], atol=1e-12)
    xbar, ybar = rng_true, brg_true
    notes = np.array([np.hypot(xbar, ybar), np.arctan2(ybar, xbar)])
    assert abs(notes[0] - rng_true) > 0.05 and abs(notes[1] - brg_true) > 0.3
    # the notes' form is not even scale-covariant: doubling the world does not double its "range"
    big = np.hypot(2 * rng_true, brg_true)
    assert abs(big - 2 * notes[0]) > 0.05
    np.testing.assert_allclose(observe(2 * pose * [1, 1, 0] + [0, 0, -0.5], 2 * m)[0], 2 * rng_true)


def test_E6_bearing_innovation_and_yaw_are_wrapped():
    """000/004: ``y = z − zp`` unwrapped. A landmark behind the robot seen at +π − ε while predicted at
    −π + ε is a 2ε innovation, not 2π − 2ε."""
    ekf = EKFSLAM(initial_pose=[0.0, 0.0, 0.0], initial_cov=[0.01, 0.01, 0.01], range_bearing_cov=[0.01, 0.001])
    ekf.update(np.array([[5.0, -np.pi + 0.01, 0]]))
    before = ekf.x.copy()
    z = np.array([[5.0, np.pi - 0.01, 0]])
    ekf.update(z)
    assert abs(wrap_angle(ekf.x[2] - before[2])) < 0.03
    assert np.abs(ekf.x[3:] - before[3:]).max() < 0.2
    assert ekf.nis_log[-1][0] < 1.0
    # the unwrapped innovation of the notes: a 2π bearing error, NIS in the thousands
    nu_notes = z[0, :2] - observe(before[:3], before[3:])
    assert abs(nu_notes[1]) > 6.0
    # yaw stays in (−π, π] through many turns
    for _ in range(100):
        ekf.predict((0.0, 1.0), 0.5)
    assert -np.pi < ekf.x[2] <= np.pi


def test_E7_initP_drops_the_robot_landmark_correlation_that_monte_carlo_shows():
    """000 augments P with ``[[PEst, 0], [0, initP]]``. Monte Carlo of (robot error, new-landmark error)
    shows the cross-covariance P_rr G_xᵀ that init="jacobian" keeps and init="initP" sets to zero."""
    rng = np.random.default_rng(2)
    x_true, m_true = X0, np.array([6.0, 5.0])
    R = np.diag([0.01, 0.0004])
    z_true = observe(x_true, m_true)
    K = 200_000
    x_est = rng.multivariate_normal(x_true, P0, size=K)
    z = z_true + rng.multivariate_normal(np.zeros(2), R, size=K)
    err = np.column_stack([x_est - x_true, inverse_observe(x_est, z) - m_true])
    mc = np.cov(err.T)
    good = EKFSLAM(initial_pose=x_true, initial_cov=P0, range_bearing_cov=R)
    good.update(np.array([[z_true[0], z_true[1], 0]]))
    bad = EKFSLAM(initial_pose=x_true, initial_cov=P0, range_bearing_cov=R, init="initP", init_cov=1.0)
    bad.update(np.array([[z_true[0], z_true[1], 0]]))
    assert _rel(good.P, mc) < 0.03
    assert _rel(good.P[3:, :3], mc[3:, :3]) < 0.03
    np.testing.assert_array_equal(bad.P[3:, :3], 0.0)
    Gx, _ = inverse_observation_jacobians(x_true, z_true)
    assert np.linalg.norm(mc[3:, :3]) > 0.5 * np.linalg.norm(Gx @ P0)  # the correlation is real and large
