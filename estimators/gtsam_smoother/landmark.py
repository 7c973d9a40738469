"""Landmark-SLAM factor graph shared by the batch and the incremental (iSAM2) smoother.

Graph (K poses x_0…x_{K−1} ∈ SE(2), L landmarks l_j ∈ R²)::

    p(x_0)                 PriorFactorPose2        x_0 ~ start pose, Σ_0 = diag(prior_sigma²)
    p(x_k | x_{k−1})       BetweenFactorPose2      x_{k−1}⁻¹ x_k ≈ δ_k,  Σ_k = Jᵀ P_δ J   (3×3)
    p(z_i | x_k, l_j)      BearingRangeFactor2D    (bearing, range) = h(x_k, l_j) + v, v ~ N(0, R) (2×2)
    p(r_i | x_k, l_j)      RangeFactor2D           r_i − β = ‖l_j − p_k‖ + w, w ~ N(0, σ_r²)   (beacon ranges)
    p(l_j)                 PriorFactorPoint2       l_j ~ surveyed position, σ = beacon_prior_sigma (anchored beacons)

with δ_k, P_δ from the filters' motion model and noise (:mod:`.problem`, :mod:`.noise`) so the
graph and the EKF use the same noise. MAP estimate: ``argmin Σ ‖e‖²_Σ`` (robust kernels optional
on the observation and beacon-range factors). Pose covariances are converted from GTSAM's body frame to the
world (x, y, θ) frame of :class:`~slamarena.datasets.estimate.Estimate`.

Parameters common to both smoothers: :class:`LandmarkSmootherParams` — the problem's
(:class:`~.problem.LandmarkProblemParams`: motion model, extra pose keys, regularisation, start prior,
noise overrides, beacon-range noise and offset), the robust kernel on the observation and beacon-range
factors (:class:`~.graph.RobustKernelParams`), whether to compute marginals, and ``beacon_prior_sigma``:
anchor every ranged beacon that ``sequence.landmarks`` locates (localization against surveyed beacons),
or ``None``: leave the beacons free (range-only SLAM; batch only, beacons initialised by trilateration
from the batch smoother's initial poses, :meth:`LandmarkProblem.trilaterate`). :class:`LandmarkSmoother` is the
behaviour both smoothers share.
"""

from __future__ import annotations

import gtsam
import numpy as np

from slamarena.datasets.sequence import Sequence
from slamarena.params import Field

from .graph import ComputeCovariances, L, RobustKernelParams
from .problem import LandmarkProblem, LandmarkProblemParams, PositiveFinite, build_problem

__all__ = ["LandmarkSmootherParams", "LandmarkSmoother"]


class LandmarkSmootherParams(LandmarkProblemParams, RobustKernelParams):
    """Parameters of both landmark smoothers (:class:`LandmarkSmoother`)."""

    covariances: ComputeCovariances = True
    beacon_prior_sigma: PositiveFinite | None = Field(
        1e-3,
        description="σ of the prior that holds each ranged beacon at its surveyed position (sequence.landmarks) [m]; "
        "None: beacons free (range-only SLAM, batch only)",
    )


class LandmarkSmoother:
    """What the batch and the incremental smoother share: the problem of a sequence, the start prior and the
    beacon anchors (:class:`LandmarkSmootherParams`; each smoother extends the model)."""

    Params = LandmarkSmootherParams

    def __init__(self, params: LandmarkSmootherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.prior_cov = np.diag(np.square(self.params.prior_sigma))

    def problem(self, sequence: Sequence) -> LandmarkProblem:
        return build_problem(sequence, self.params)

    def anchored_beacons(self, problem: LandmarkProblem) -> np.ndarray:
        """Ids of the ranged beacons held at their surveyed positions (none when beacon_prior_sigma is None)."""
        ids = np.unique(problem.rng_id)
        return np.zeros(0, np.int64) if self.params.beacon_prior_sigma is None else ids[problem.known_positions(ids)]

    def free_beacons(self, problem: LandmarkProblem) -> np.ndarray:
        """Ids of the ranged beacons neither anchored nor observed by a bearing and range: only their ranges place them."""
        return np.setdiff1d(problem.rng_id, np.union1d(self.anchored_beacons(problem), problem.obs_id))

    def beacon_prior(self, problem: LandmarkProblem, j: int) -> gtsam.PriorFactorPoint2:
        sigma = gtsam.noiseModel.Isotropic.Sigma(2, float(self.params.beacon_prior_sigma))
        return gtsam.PriorFactorPoint2(L(j), gtsam.Point2(*problem.map_position(j)), sigma)
