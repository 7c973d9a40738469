"""Noise mapping between the filters' motion models and GTSAM's factors (numpy only).

Relative motion between two pose keys
-------------------------------------
The filters propagate ``x ← f(x, u)`` with ``P ← G P Gᵀ + V M Vᵀ`` (Twist input, M = twist
covariance (2, 2)) or ``P ← Jx P Jxᵀ + Jδ C Jδᵀ`` (Increments input, C (3, 3)). Run from the
identity with ``P = 0``, the same recursion gives the relative pose ``δ`` from key ``a`` to key
``b`` (expressed in the frame of ``a``) and its covariance ``P_δ`` in additive ``(x, y, θ)``
coordinates of that frame — exactly the uncertainty the EKF adds between the two stamps.

GTSAM's ``BetweenFactor<Pose2>`` error is ``Log(δ_meas⁻¹ · (x_a⁻¹ x_b))``: a perturbation on the
right of ``δ``, i.e. in the frame of the *end* pose ``b``. To first order
``δ · Exp(ξ) ≈ (t_δ + R(θ_δ) ξ_xy, θ_δ + ξ_θ)``, so the additive error is ``J ξ`` with
``J = blockdiag(R(θ_δ), 1)`` and the factor's covariance is ``Σ_ξ = Jᵀ P_δ J`` (:func:`world_to_body`).

Pose covariances
----------------
The same relation holds for a pose ``x̂`` and its marginal: GTSAM reports ``Σ_body`` of ξ with
``x = x̂ · Exp(ξ)``; the world-frame ``(x, y, θ)`` covariance of :class:`~slamarena.datasets.estimate.Estimate`
is ``J Σ_body Jᵀ`` with ``J = blockdiag(R(θ̂), 1)`` (:func:`body_to_world`).

One twist piece has a rank-2 covariance (two noise inputs for three pose coordinates); an
independent factor needs a positive-definite one, so :func:`regularise` lifts the eigenvalues
to a small fraction of the largest (default 1e-4, i.e. a standard deviation 1 % of the largest one: the
constraint becomes stiff, not exact; a smaller floor makes the problem so ill-conditioned that
Gauss-Newton diverges and Levenberg-Marquardt needs ten times the iterations).
"""
from __future__ import annotations

import numpy as np

from slamarena.datasets.geometry import compose, rotation
from slamarena.estimators.models import MotionModel, compose_jacobians

__all__ = ["twist_relative", "increments_relative", "body_to_world", "world_to_body", "regularise"]


def twist_relative(model: MotionModel, v: np.ndarray, omega: np.ndarray, dt: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Relative pose δ (3,) over the twist pieces ``(v, ω, dt)`` and its additive covariance P (3, 3)
    in the frame of the first pose: ``P ← G P Gᵀ + V M Vᵀ`` from ``δ = 0, P = 0``."""
    delta = np.zeros(3)
    P = np.zeros((3, 3))
    for vk, wk, dk in zip(v, omega, dt):
        G, V = model.jacobians(delta, vk, wk, dk)
        P = G @ P @ G.T + V @ M @ V.T
        delta = model.predict(delta, vk, wk, dk)
    return delta, P


def increments_relative(deltas: np.ndarray, covs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Composition δ = δ_1 ⊕ … ⊕ δ_K (3,) of body-frame increments (K, 3) with covariances
    (K, 3, 3), and its additive covariance ``P ← Jx P Jxᵀ + Jδ C Jδᵀ`` in the frame of the first pose."""
    delta = np.zeros(3)
    P = np.zeros((3, 3))
    for d, C in zip(deltas, covs):
        Jx, Jd = compose_jacobians(delta, d)
        P = Jx @ P @ Jx.T + Jd @ C @ Jd.T
        delta = compose(delta, d)
    return delta, P


def _frame(theta: np.ndarray | float) -> np.ndarray:
    """J = blockdiag(R(θ), 1), shape ``θ.shape + (3, 3)``."""
    theta = np.asarray(theta, dtype=float)
    J = np.zeros(theta.shape + (3, 3))
    J[..., :2, :2] = rotation(theta)
    J[..., 2, 2] = 1.0
    return J


def body_to_world(theta: np.ndarray | float, cov_body: np.ndarray) -> np.ndarray:
    """World-frame (x, y, θ) covariance ``J Σ Jᵀ`` of a pose with heading θ and body-frame Σ (broadcasts)."""
    J = _frame(theta)
    return J @ cov_body @ np.swapaxes(J, -1, -2)


def world_to_body(theta: np.ndarray | float, cov_world: np.ndarray) -> np.ndarray:
    """Body-frame (right-perturbation) covariance ``Jᵀ P J`` (inverse of :func:`body_to_world`)."""
    J = _frame(theta)
    return np.swapaxes(J, -1, -2) @ cov_world @ J


def regularise(P: np.ndarray, floor: float) -> np.ndarray:
    """Symmetrise P and lift its eigenvalues to at least ``floor · λ_max`` (``floor ≤ 0``: unchanged)."""
    P = 0.5 * (P + P.T)
    if floor <= 0:
        return P
    lam, U = np.linalg.eigh(P)
    lam = np.maximum(lam, floor * max(lam[-1], np.finfo(float).tiny))
    return (U * lam) @ U.T
