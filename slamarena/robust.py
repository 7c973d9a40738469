"""Robust kernels on GTSAM factors, shared by the factor-graph estimators (:mod:`slamarena.estimators.gtsam_smoother`)
and laser graph SLAM's back end (:mod:`slamarena.mapping.laser_slam`), which are side-by-side layers.

A factor's noise is ``Gaussian.Covariance(Σ)`` (or ``Information``), optionally wrapped in ``Robust`` with a Huber
or Cauchy m-estimator of width ``k`` in units of the whitened error (standard deviations): a residual of
whitened size e costs e²/2 up to k and grows linearly (Huber) or logarithmically (Cauchy, ρ = k²/2 log(1 + e²/k²))
beyond, so one wrong constraint cannot pull the solution by more than its bounded influence.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import PositiveFloat

from .params import Field, Params

__all__ = ["RobustKernelParams", "robustify", "noise_model", "information_model"]


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
