"""Landmark-SLAM factor graph shared by the batch and the incremental (iSAM2) smoother.

Graph (K poses x_0…x_{K−1} ∈ SE(2), L landmarks l_j ∈ R²)::

    p(x_0)                 PriorFactorPose2        x_0 ~ start pose, Σ_0 = diag(prior_sigma²)
    p(x_k | x_{k−1})       BetweenFactorPose2      x_{k−1}⁻¹ x_k ≈ δ_k,  Σ_k = Jᵀ P_δ J   (3×3)
    p(z_i | x_k, l_j)      BearingRangeFactor2D    (bearing, range) = h(x_k, l_j) + v, v ~ N(0, R) (2×2)

with δ_k, P_δ from the filters' motion model and noise (:mod:`.problem`, :mod:`.noise`) so the
graph and the EKF use the same noise. MAP estimate: ``argmin Σ ‖e‖²_Σ`` (robust kernels optional
on the observation factors). Pose covariances are converted from GTSAM's body frame to the
world (x, y, θ) frame of :class:`~datasets.estimate.Estimate`.

Parameters common to both smoothers (keyword-only, with defaults):
    motion_model "arc"|"euler"; max_interval (s) or None: extra pose keys; regularisation: eigen-
    value floor of one between factor relative to its largest (1e-4); prior_sigma (x, y, θ);
    robust "none"|"huber"|"cauchy" with robust_k; covariances: compute marginals;
    twist_cov / increment_cov / range_bearing_cov: override the sequence's stated noise.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datasets.sequence import Sequence

from .graph import ROBUST, check_choice
from .problem import LandmarkProblem, build_problem

__all__ = ["LandmarkSmootherConfig"]


@dataclass(kw_only=True)
class LandmarkSmootherConfig:
    motion_model: str = "arc"
    max_interval: float | None = None
    regularisation: float = 1e-4
    prior_sigma: list[float] = field(default_factory=lambda: [1e-3, 1e-3, 1e-3])
    robust: str = "none"
    robust_k: float = 1.345
    covariances: bool = True
    twist_cov: list | None = None
    increment_cov: list | None = None
    range_bearing_cov: list | None = None

    def __post_init__(self):
        check_choice("robust", self.robust, ROBUST)
        sigma = np.asarray(self.prior_sigma, dtype=float)
        if sigma.shape != (3,) or not np.all(np.isfinite(sigma)) or np.any(sigma <= 0):
            raise ValueError(f"prior_sigma must be three positive numbers; got {self.prior_sigma!r}")
        if not self.robust_k > 0:
            raise ValueError("robust_k must be > 0")
        if not 0 <= self.regularisation < 1:
            raise ValueError("regularisation must be in [0, 1)")
        if self.max_interval is not None and not self.max_interval > 0:
            raise ValueError("max_interval must be > 0 or None")

    @property
    def prior_cov(self) -> np.ndarray:
        return np.diag(np.asarray(self.prior_sigma, dtype=float) ** 2)

    def problem(self, sequence: Sequence) -> LandmarkProblem:
        return build_problem(
            sequence,
            motion_model=self.motion_model,
            max_interval=self.max_interval,
            regularisation=self.regularisation,
            twist_cov=self.twist_cov,
            increment_cov=self.increment_cov,
            range_bearing_cov=self.range_bearing_cov,
        )
