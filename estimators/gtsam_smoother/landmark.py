"""Landmark-SLAM factor graph shared by the batch and the incremental (iSAM2) smoother.

Graph (K poses x_0…x_{K−1} ∈ SE(2), L landmarks l_j ∈ R²)::

    p(x_0)                 PriorFactorPose2        x_0 ~ start pose, Σ_0 = diag(prior_sigma²)
    p(x_k | x_{k−1})       BetweenFactorPose2      x_{k−1}⁻¹ x_k ≈ δ_k,  Σ_k = Jᵀ P_δ J   (3×3)
    p(z_i | x_k, l_j)      BearingRangeFactor2D    (bearing, range) = h(x_k, l_j) + v, v ~ N(0, R) (2×2)
    p(r_i | x_k, l_j)      RangeFactor2D           r_i − β = ‖l_j − p_k‖ + w, w ~ N(0, σ_r²)   (beacon ranges)
    p(l_j)                 PriorFactorPoint2       l_j ~ surveyed position, σ = beacon_prior_sigma (anchored beacons)

with δ_k, P_δ from the filters' motion model and noise (:mod:`.problem`, :mod:`.noise`) so the
graph and the EKF use the same noise. MAP estimate: ``argmin Σ ‖e‖²_Σ`` (robust kernels optional
on the observation factors). Pose covariances are converted from GTSAM's body frame to the
world (x, y, θ) frame of :class:`~slamarena.datasets.estimate.Estimate`.

Parameters common to both smoothers (keyword-only, with defaults):
    motion_model "arc"|"euler"; max_interval (s) or None: extra pose keys; regularisation: eigen-
    value floor of one between factor relative to its largest (1e-4); prior_sigma (x, y, θ);
    robust "none"|"huber"|"cauchy" with robust_k; covariances: compute marginals;
    twist_cov / increment_cov / range_bearing_cov: override the sequence's stated noise;
    beacon_range_var σ_r² [m²] and beacon_bias β [m] of range-only beacons; beacon_prior_sigma [m]:
    anchor every ranged beacon that ``sequence.landmarks`` locates (localization against surveyed
    beacons), or ``None``: leave the beacons free (range-only SLAM; batch only, beacons initialised by
    trilateration from the dead-reckoned poses, :meth:`LandmarkProblem.trilaterate`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slamarena.datasets.sequence import Sequence

import gtsam

from .graph import ROBUST, L, check_choice
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
    beacon_range_var: float = 1.0
    beacon_bias: float = 0.0
    beacon_prior_sigma: float | None = 1e-3

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
        if not (np.isfinite(self.beacon_range_var) and self.beacon_range_var > 0) or not np.isfinite(self.beacon_bias):
            raise ValueError("beacon_range_var must be > 0 and beacon_bias a finite number of metres")
        if self.beacon_prior_sigma is not None and not self.beacon_prior_sigma > 0:
            raise ValueError("beacon_prior_sigma must be > 0 or None")

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
            beacon_range_var=self.beacon_range_var,
            beacon_bias=self.beacon_bias,
        )

    def anchored_beacons(self, problem: LandmarkProblem) -> np.ndarray:
        """Ids of the ranged beacons held at their surveyed positions (none when beacon_prior_sigma is None)."""
        ids = np.unique(problem.rng_id)
        return np.zeros(0, np.int64) if self.beacon_prior_sigma is None else ids[problem.known_positions(ids)]

    def beacon_prior(self, problem: LandmarkProblem, j: int) -> gtsam.PriorFactorPoint2:
        sigma = gtsam.noiseModel.Isotropic.Sigma(2, float(self.beacon_prior_sigma))
        return gtsam.PriorFactorPoint2(L(j), gtsam.Point2(*problem.map_position(j)), sigma)
