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

Stiffness relative to the pose's uncertainty (iSAM2)
----------------------------------------------------
That floor is relative to the factor itself, so a between factor stays up to 100× stiffer in its
weakest direction than in its strongest (σ_min = 1e-4 m over a 0.1 s step, 4·10⁻⁶ m over the
1 ms gaps between MRCLAM observation sets). Whether Cholesky accepts that depends on how uncertain
the pose is: GTSAM 4.3 rejects a frontal block as indeterminate when a pivot keeps less than 2⁻²⁴
of its diagonal (R_ii² < 2⁻²⁴ A_ii), and eliminating x_{k−1} before x_k in one clique (iSAM2's root
at every step) leaves x_k a pivot R_ii² ≈ 1/σ²(x_k,i | rest) against a diagonal A_ii ≈ 1/σ_min² — a
failure as soon as the pose's uncertainty exceeds 2¹² σ_min. :func:`floor_to_uncertainty` lifts the
factor's covariance so that, at each end, in coordinates scaled by that pose's conditional standard
deviations D = diag(σ(x|y,θ), σ(y|θ), σ(θ)), every eigenvalue of D⁻¹ C D⁻¹ is ≥ ε (iSAM2's default
2⁻²²: no direction more than 2¹¹ times tighter than the pose's uncertainty, a margin of 4 on the test).
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.geometry import compose, rotation
from slamarena.estimators.models import MotionModel, compose_jacobians

__all__ = [
    "twist_relative",
    "twist_relatives",
    "increments_relative",
    "body_to_world",
    "world_to_body",
    "regularise",
    "floor_to_uncertainty",
]


def twist_relative(
    model: MotionModel, v: np.ndarray, omega: np.ndarray, dt: np.ndarray, M: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Relative pose δ (3,) over the twist pieces ``(v, ω, dt)`` and its additive covariance P (3, 3)
    in the frame of the first pose: ``P ← G P Gᵀ + V M Vᵀ`` from ``δ = 0, P = 0``."""
    delta, P = twist_relatives(model, v, omega, dt, np.zeros(np.size(v), dtype=np.int64), 1, M)
    return delta[0], P[0]


def twist_relatives(
    model: MotionModel, v: np.ndarray, omega: np.ndarray, dt: np.ndarray, group: np.ndarray, n: int, M: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`twist_relative` of ``n`` intervals at once: the pieces (P,) in time order, ``group`` (P,) the interval of
    each (non-decreasing, in [0, n)); returns δ (n, 3) and P (n, 3, 3) (zero for an interval without pieces). The
    recursion runs over the pieces' rank within their interval, each step on every interval that has that many
    pieces: the same operations on each interval as one call per interval, so the same numbers bit for bit."""
    group = np.asarray(group, dtype=np.int64)
    delta, P = np.zeros((n, 3)), np.zeros((n, 3, 3))
    first = np.searchsorted(group, group, side="left")  # each piece's interval begins at this piece
    rank = np.arange(group.size) - first
    for r in range(int(rank.max(initial=-1)) + 1):
        pieces = np.flatnonzero(rank == r)
        at = group[pieces]
        G, V = model.jacobians(delta[at], v[pieces], omega[pieces], dt[pieces])
        P[at] = G @ P[at] @ np.swapaxes(G, -1, -2) + V @ M @ np.swapaxes(V, -1, -2)
        delta[at] = model.predict(delta[at], v[pieces], omega[pieces], dt[pieces])
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
    """Symmetrise P (..., 3, 3) and lift each one's eigenvalues to at least ``floor · λ_max`` (``floor ≤ 0``:
    unchanged)."""
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    if floor <= 0:
        return P
    lam, U = np.linalg.eigh(P)
    lam = np.maximum(lam, floor * np.maximum(lam[..., -1:], np.finfo(float).tiny))
    return (U * lam[..., None, :]) @ np.swapaxes(U, -1, -2)


def _adjoint_of_inverse(delta: np.ndarray) -> np.ndarray:
    """Ad(δ⁻¹) (3, 3): maps a right perturbation of x_a to the one of x_b = x_a δ (GTSAM's Pose2 tangent order)."""
    c, s = np.cos(delta[2]), np.sin(delta[2])
    R_inv = np.array([[c, s], [-s, c]])
    t_inv = -R_inv @ delta[:2]
    Ad = np.eye(3)
    Ad[:2, :2] = R_inv
    Ad[:2, 2] = [t_inv[1], -t_inv[0]]
    return Ad


def _conditional_sigmas(S: np.ndarray) -> np.ndarray:
    """σ(x | y, θ), σ(y | θ), σ(θ) of a pose covariance S (3, 3) in GTSAM's (x, y, θ) order: Cholesky's pivots in that
    order are at least their inverses (R_ii² ≥ 1 / σ_i², whatever else the clique conditions on)."""
    return np.array(
        [1.0 / np.sqrt(np.linalg.inv(S)[0, 0]), 1.0 / np.sqrt(np.linalg.inv(S[1:, 1:])[0, 0]), np.sqrt(S[2, 2])]
    )


def _lift(C: np.ndarray, d: np.ndarray, eps: float) -> np.ndarray:
    """C with the eigenvalues of D⁻¹ C D⁻¹ (D = diag(d)) raised to ≥ eps; C itself when none is below."""
    scaled = C / np.outer(d, d)
    lam, U = np.linalg.eigh(0.5 * (scaled + scaled.T))
    if lam[0] >= eps:
        return C
    return ((U * np.maximum(lam, eps)) @ U.T) * np.outer(d, d)


def floor_to_uncertainty(C: np.ndarray, pose_cov: np.ndarray, delta: np.ndarray, eps: float) -> np.ndarray:
    """Between-factor covariance C (3, 3; body frame of x_b = x_a δ) lifted so that it is nowhere stiffer than
    ``eps`` times the uncertainty of either pose it joins.

    Σ_a = ``pose_cov`` (marginal of x_a, its body frame), Σ_b = A Σ_a Aᵀ + C with A = Ad(δ⁻¹) (the prediction of x_b:
    an upper bound of its marginal once the step's factors are added). At each end e the factor's covariance is
    C_b = C, C_a = A⁻¹ C A⁻ᵀ, and D_e = diag(σ(x|y,θ), σ(y|θ), σ(θ)) of Σ_e; the rule is
    λ_min(D_e⁻¹ C_e D_e⁻¹) ≥ eps at both ends. Then the factor adds at most 1/(eps σ_i²) to the diagonal of any
    coordinate of either pose whose Cholesky pivot is at least 1/σ_i², so the pivot keeps ≥ eps of the diagonal that
    factor contributes (GTSAM 4.3 needs 2⁻²⁴). Returns C itself when it already satisfies the rule.
    """
    A = _adjoint_of_inverse(np.asarray(delta, dtype=float))
    A_inv = np.linalg.inv(A)
    C_b = _lift(C, _conditional_sigmas(A @ pose_cov @ A.T + C), eps)
    C_a = A_inv @ C_b @ A_inv.T
    lifted_a = _lift(C_a, _conditional_sigmas(pose_cov), eps)
    if lifted_a is C_a:
        return C_b
    out = A @ lifted_a @ A.T
    return 0.5 * (out + out.T)
