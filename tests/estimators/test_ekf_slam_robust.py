"""EKF-SLAM's heavy-tailed measurement update (``robust_update``: Huber or Student-t IRLS weights,
:func:`slamarena.robust.kalman_weights`) and per-observation noise covariances (``R`` of ``update``, the sequence's
``meta["range_bearing_cov_per_observation"]`` in ``run``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.association import Decision
from slamarena.estimators.models import observe
from slamarena.robust import huber_weight, kalman_weights


def _linear_problem(rng, n=4, m=3):
    """m observations (2,) of a linear model z_j = H_j x + e_j, a Gaussian prior N(x⁻, P) on x (n,)."""
    L = 0.1 * rng.normal(size=(n, n))
    P = L @ L.T + 0.01 * np.eye(n)
    H = rng.normal(size=(m, 2, n))
    R = np.stack([np.diag(rng.uniform(0.05, 0.3, 2)) for _ in range(m)])
    return P, H, R


def test_the_huber_weight_is_the_minimiser_of_the_huber_objective(rng):
    """Each row alone: x⁺ of the Kalman update with R / w (w the IRLS fixed point) minimises
    ½‖x − x⁻‖²_P⁻¹ + ρ_k(‖z − Hx‖_R⁻¹) — checked against a direct numerical minimisation (scipy), for an inlier
    (w = 1, the Gaussian update) and a gross outlier (w ≪ 1)."""
    P, H, R = _linear_problem(rng)
    x0 = np.zeros(4)
    k = 1.5
    nu = np.stack([0.05 * rng.normal(size=2), np.array([8.0, -5.0]), np.array([1.0, 1.5])])
    A = H @ P @ H.transpose(0, 2, 1)
    w = kalman_weights(nu, A, R, "huber", k=k)
    assert w[0] == 1.0 and w[1] < 0.2
    Pinv = np.linalg.inv(P)
    for j in range(len(nu)):
        Rinv = np.linalg.inv(R[j])
        chol = np.linalg.cholesky(Rinv)

        def objective(x, j=j, Rinv=Rinv, chol=chol):
            r = np.linalg.norm(chol.T @ (nu[j] - H[j] @ x))
            rho = 0.5 * r**2 if r <= k else k * r - 0.5 * k**2
            return 0.5 * (x - x0) @ Pinv @ (x - x0) + rho

        best = minimize(objective, x0, method="BFGS", options={"gtol": 1e-10}).x
        S = A[j] + R[j] / w[j]
        x_kalman = x0 + P @ H[j].T @ np.linalg.solve(S, nu[j])
        np.testing.assert_allclose(x_kalman, best, atol=1e-5)


def test_the_student_t_weight_is_its_variational_fixed_point(rng):
    """The Student-t weight equals (ν + 2) / (ν + E[‖z − Hx‖²_R⁻¹]) with the expectation over the posterior of the
    update with R / w, computed literally with the dense posterior (x⁺, P⁺) — the efficient 2 × 2 form checked."""
    P, H, R = _linear_problem(rng)
    nu = np.stack([0.1 * rng.normal(size=2), np.array([6.0, -4.0]), np.array([0.5, 0.8])])
    A = H @ P @ H.transpose(0, 2, 1)
    dof = 4.0
    w = kalman_weights(nu, A, R, "student_t", dof=dof)
    for j in range(len(nu)):
        S = H[j] @ P @ H[j].T + R[j] / w[j]
        K = P @ H[j].T @ np.linalg.inv(S)
        x_post, P_post = K @ nu[j], P - K @ S @ K.T
        e = nu[j] - H[j] @ x_post
        Rinv = np.linalg.inv(R[j])
        expected = e @ Rinv @ e + np.trace(Rinv @ H[j] @ P_post @ H[j].T)
        assert w[j] == pytest.approx((dof + 2) / (dof + expected), rel=1e-8)
    assert w[1] < 0.1 < w[0]


def test_huber_weight_is_one_inside_the_width_and_bounds_the_influence_beyond():
    r = np.array([0.0, 1.0, 2.0, 4.0, 40.0])
    w = huber_weight(r, 2.0)
    np.testing.assert_array_equal(w[:3], 1.0)
    np.testing.assert_allclose(w[3:] * r[3:], 2.0)  # ψ(r) = w r = k beyond k


def _mapped(**kw) -> EKFSLAM:
    """A filter that has mapped landmarks 0 and 1 and moved since (labelled rows, no gate)."""
    ekf = EKFSLAM(initial_cov=[0.01, 0.01, 0.001], twist_cov=[0.01, 0.0025], known_confidence=None, **kw)
    ekf.update(np.array([[5.0, 0.3, 0], [4.0, -0.5, 1]]))
    ekf.predict((1.0, 0.1), 0.5)
    return ekf


@pytest.mark.parametrize("kw", [{}, {"update": "batch"}, {"defer_covariance": False}])
def test_the_huber_update_is_the_standard_update_on_inliers(kw):
    """Rows whose innovations lie inside the Huber width (here the predicted measurements plus a small offset): weight 1,
    x and P bitwise those of the Gaussian filter."""
    plain, huber = _mapped(**kw), _mapped(robust_update="huber", **kw)
    z = np.column_stack([observe(plain.x[:3], plain.x[3:].reshape(-1, 2)) + [0.02, -0.005], [0, 1]])
    plain.update(z)
    huber.update(z)
    np.testing.assert_array_equal(huber.x, plain.x)
    np.testing.assert_array_equal(huber.P, plain.P)
    assert huber.weight_log[-2:] == [1.0, 1.0]


@pytest.mark.parametrize("kernel", ["huber", "student_t"])
def test_the_robust_update_down_weights_a_gross_outlier(kernel):
    """A labelled bearing 1 rad off (no gate): the Gaussian update turns the robot by 0.35 rad, the robust one by a
    small part of that, with the row's weight logged; a good row in the same set is applied at (nearly) full weight."""
    plain, robust = _mapped(), _mapped(robust_update=kernel)
    zhat = observe(plain.x[:3], plain.x[3:].reshape(-1, 2))
    z = np.column_stack([zhat + [[0.0, 1.0], [0.01, 0.0]], [0, 1]])
    before = plain.x.copy()
    plain.update(z)
    robust.update(z)
    turned_plain, turned_robust = abs(plain.x[2] - before[2]), abs(robust.x[2] - before[2])
    assert turned_plain > 0.3 and turned_robust < 0.2 * turned_plain
    assert robust.weight_log[-2] < 0.1 and robust.weight_log[-1] > 0.5
    assert [d for d, *_ in robust.assoc_log[-2:]] == [Decision.MATCHED, Decision.MATCHED]


def test_per_row_covariances_are_the_filter_noise_when_equal_and_change_the_update_when_not():
    """``update(z, R=...)`` with every R_j the filter's R equals ``update(z)``; with R_j = 4 R it equals a filter whose
    range_bearing_cov is 4 R; a row whose R_j is not positive definite is dropped and counted, the rest applied."""
    a, b = _mapped(), _mapped()
    z = np.column_stack([observe(a.x[:3], a.x[3:].reshape(-1, 2)) + [0.1, 0.02], [0, 1]])
    a.update(z)
    b.update(z, R=np.broadcast_to(b.R, (2, 2, 2)))
    np.testing.assert_array_equal(a.x, b.x)
    R4 = np.broadcast_to(4 * a.R, (2, 2, 2))
    c, d = (
        EKFSLAM(initial_cov=[0.01, 0.01, 0.001], known_confidence=None, **kw)
        for kw in ({"range_bearing_cov": R4[0]}, {})
    )
    for filt, R in ((c, None), (d, R4)):
        filt.update(np.array([[5.0, 0.3, 0], [4.0, -0.5, 1]]), R=R)
        filt.predict((1.0, 0.1), 0.5)
        filt.update(z, R=R)
    np.testing.assert_allclose(c.x, d.x, atol=1e-12)
    np.testing.assert_allclose(c.P, d.P, atol=1e-12)
    e, f = _mapped(), _mapped()
    bad = np.stack([f.R, -f.R])
    e.update(z[:1])
    f.update(z, R=bad)
    np.testing.assert_array_equal(e.x, f.x)
    assert f.rejected["covariance"] == 1 and e.rejected["covariance"] == 0
    with pytest.raises(ValueError, match="one 2 × 2 covariance per row"):
        f.update(z, R=np.eye(2))


def test_run_takes_the_sequences_per_observation_covariance():
    """A sequence stating a covariance per row (meta, as the landmark extractor does): run() updates each row with its
    own — equal to a filter given that R when all rows share it; unused when range_bearing_cov is given or
    per_observation_cov=False."""
    seq = datasets.load("sim:landmarks", n_landmarks=20, seed=3)
    R4 = 4 * seq.noise.range_bearing_cov
    stated = replace(
        seq,
        meta={**seq.meta, "range_bearing_cov_per_observation": np.broadcast_to(R4, (len(seq.range_bearing.t), 2, 2))},
    )
    per_row = EKFSLAM().run(stated)
    given = EKFSLAM(range_bearing_cov=R4).run(seq)
    np.testing.assert_allclose(per_row.poses, given.poses, atol=1e-9)
    off = EKFSLAM(per_observation_cov=False).run(stated)
    np.testing.assert_array_equal(off.poses, EKFSLAM().run(seq).poses)
    short = replace(seq, meta={**seq.meta, "range_bearing_cov_per_observation": np.broadcast_to(R4, (3, 2, 2))})
    with pytest.raises(ValueError, match="range_bearing_cov_per_observation"):
        EKFSLAM().run(short)
