"""Robust kernels: on GTSAM factors, shared by the factor-graph estimators (:mod:`slamarena.estimators.gtsam_smoother`)
and laser graph SLAM's back end (:mod:`slamarena.mapping.laser_slam`), which are side-by-side layers.

A factor's noise is ``Gaussian.Covariance(Σ)`` (or ``Information``), optionally wrapped in ``Robust`` with a Huber
or Cauchy m-estimator of width ``k`` in units of the whitened error (standard deviations): a residual of
whitened size e costs e²/2 up to k and grows linearly (Huber) or logarithmically (Cauchy, ρ = k²/2 log(1 + e²/k²))
beyond, so one wrong constraint cannot pull the solution by more than its bounded influence.

And on the filters' Kalman update (:func:`kalman_weights`, numpy): the IRLS weights of a Huber or Student-t measurement
update, used by EKF-SLAM (``robust_update``; the section below states the equations).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import PositiveFloat

from .params import Field, Params

__all__ = [
    "RobustKernelParams",
    "robustify",
    "noise_model",
    "information_model",
    "KalmanKernel",
    "huber_weight",
    "student_t_weight",
    "kalman_weights",
]


class RobustKernelParams(Params):
    """The robust kernel on the factors that may hold outliers (observations, GPS, loop closures)."""

    robust: Literal["none", "huber", "cauchy"] = Field(
        "none", description="m-estimator of those factors; none: plain least squares"
    )
    robust_k: PositiveFloat = Field(
        1.345, description="width of the m-estimator [standard deviations of the whitened error]"
    )


def robustify(base, kernel: RobustKernelParams | None):
    """``base`` wrapped in the kernel's Huber or Cauchy m-estimator of width ``robust_k`` (no kernel or
    ``robust="none"``: unchanged)."""
    import gtsam

    if kernel is None or kernel.robust == "none":
        return base
    estimator = {"huber": gtsam.noiseModel.mEstimator.Huber, "cauchy": gtsam.noiseModel.mEstimator.Cauchy}[
        kernel.robust
    ]
    return gtsam.noiseModel.Robust.Create(estimator.Create(kernel.robust_k), base)


def noise_model(cov: np.ndarray, kernel: RobustKernelParams | None = None):
    """Gaussian noise with covariance ``cov``, robustified by ``kernel`` when given."""
    import gtsam

    return robustify(gtsam.noiseModel.Gaussian.Covariance(np.asarray(cov, dtype=float)), kernel)


def information_model(information: np.ndarray, kernel: RobustKernelParams | None = None):
    """Gaussian noise with information matrix ``information``, robustified by ``kernel`` when given."""
    import gtsam

    return robustify(gtsam.noiseModel.Gaussian.Information(np.asarray(information, dtype=float)), kernel)


# ---------------------------------------------------------------------------------------------------------------------
# Robust weights of a Kalman update (the filters' measurement update; numpy, no GTSAM)
#
# One observation z (d,) with noise R (d × d) of a state with prior x⁻, P, linearised z ≈ h(x⁻) + H (x − x⁻):
# ν = z − h(x⁻), A = H P Hᵀ (d × d). An update with the noise R / w (a weight w ∈ (0, 1]) is the Kalman update of
# S_w = A + R / w; its posterior residual and the residual's posterior covariance are, in measurement space,
#
#     e = z − H x⁺ = (R / w) S_w⁻¹ ν ,        H P⁺ Hᵀ = A − A S_w⁻¹ A .
#
# Huber (M-estimation): x⁺ minimises ½‖x − x⁻‖²_P⁻¹ + ρ_k(‖z − H x‖_R⁻¹); its stationarity condition is the Kalman update
# with R / w at w = ψ(r) / r = min(1, k / r), r² = eᵀ R⁻¹ e — the fixed point iterated below (IRLS). A residual inside k
# keeps w = 1 exactly: the update is the standard one.
# Student-t (variational Bayes, Agamennoni, Nieto & Nebot 2012): noise N(0, R / λ), λ ~ Gamma(ν/2, ν/2); the posterior
# mean of λ given the state's posterior is w = (ν + d) / (ν + eᵀ R⁻¹ e + tr(R⁻¹ H P⁺ Hᵀ)), iterated with the update.
# ---------------------------------------------------------------------------------------------------------------------

KalmanKernel = Literal["none", "huber", "student_t"]


def huber_weight(r: np.ndarray, k: float) -> np.ndarray:
    """Huber's IRLS weight ψ(r)/r = min(1, k/r) of whitened residual norms r ≥ 0 (k: the width [σ])."""
    r = np.asarray(r, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(r <= k, 1.0, k / r)


def student_t_weight(r2: np.ndarray, dof: float, dim: int) -> np.ndarray:
    """The Student-t noise's expected precision scale (ν + d) / (ν + r²) of squared whitened residuals r² (dof ν, d dims)."""
    return (dof + dim) / (dof + np.asarray(r2, dtype=float))


def kalman_weights(
    nu: np.ndarray,
    A: np.ndarray,
    R: np.ndarray,
    kernel: KalmanKernel,
    k: float = 2.4477,
    dof: float = 5.0,
    iterations: int = 50,
    tol: float = 1e-10,
) -> np.ndarray:
    """IRLS weights w (m,) ∈ (0, 1] (Student-t: > 0) of m observations, each updated alone with noise R / w: innovations
    ν (m, d), A = H P Hᵀ (m, d, d), R (m, d, d); ``kernel`` "huber" (width k [σ of the whitened d-vector]) or "student_t"
    (dof ν); "none": all 1. The fixed point of the section above, iterated from w = 1 until no weight moves by tol."""
    nu, A, R = (np.asarray(a, dtype=float) for a in (nu, A, R))
    w = np.ones(len(nu))
    if kernel == "none" or not len(nu):
        return w
    d = nu.shape[-1]
    Rinv = np.linalg.inv(R)
    for _ in range(iterations):
        Rw = R / w[:, None, None]
        Sw_inv = np.linalg.inv(A + Rw)
        e = np.einsum("mij,mjk,mk->mi", Rw, Sw_inv, nu)
        r2 = np.einsum("mi,mij,mj->m", e, Rinv, e)
        if kernel == "huber":
            new = huber_weight(np.sqrt(r2), k)
        else:
            post = A - A @ Sw_inv @ A
            new = student_t_weight(r2 + np.einsum("mij,mji->m", Rinv, post), dof, d)
        done = np.max(np.abs(new - w)) <= tol
        w = new
        if done:
            break
    return w
