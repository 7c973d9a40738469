"""Incremental landmark-SLAM smoother: the graph of :mod:`.landmark` grown one pose at a time with iSAM2.

Step k (one ``ISAM2.update`` per pose key): the between factor x_{k−1} → x_k (the prior at k = 0)
and pose k's bearing-range and beacon-range factors; new values: x_k = x̂_{k−1} ⊕ δ_k from the
current estimate, each new landmark from its first observation seen from that predicted pose, each
new beacon at its surveyed position with its prior (a single range cannot place a beacon: range-only
SLAM with free beacons needs delayed initialisation, which this smoother does not do — it raises
and points to the batch smoother). iSAM2 relinearises
variables whose update exceeds ``relinearize_threshold`` every ``relinearize_skip`` updates.

Stiffness rule (``uncertainty_floor`` = ε, default 2⁻²²; ``None`` turns it off): before step k the between
factor's covariance C_k is lifted (:func:`.noise.floor_to_uncertainty`) so that, expressed at either pose and
scaled by that pose's conditional standard deviations σ(x|y,θ), σ(y|θ), σ(θ) (x_{k−1}'s from
``ISAM2.marginalCovariance``, x_k's predicted through the step), all its eigenvalues are ≥ ε. iSAM2
re-eliminates x_{k−1} and x_k in the root clique at every step, and GTSAM 4.3's Cholesky rejects a pivot
with R_ii² < 2⁻²⁴ A_ii: without the rule a step whose weakest direction is 2¹² times tighter than the pose's
uncertainty (a 0.1 s step of a robot 0.4 m uncertain sideways, a 1 ms step on MRCLAM) raises "indeterminate
linear system" although the system is determined. The rule changes only such factors; how many is
``diagnostics["lifted_between"]``, the covariances used are ``diagnostics["between_cov"]`` (the batch
smoother optimises that same graph when given them, :meth:`~.batch.BatchSmoother.run`).

After the last step the relinearisation threshold, the skip and the wildfire threshold are set to
zero / one (``ISAM2.params()`` is the live parameter object), and up to ``final_updates`` empty
updates relinearise every variable and re-solve (Gauss-Newton iterations on the whole graph) until
the largest change of any variable is below ``final_tol``. The result then equals the batch
optimum to that tolerance (tested against :class:`~.batch.BatchSmoother`); without this the
answer would differ from the optimum by the linearisation error the threshold allows.

Failures are :class:`~.graph.OptimizationError`, never a result: GTSAM's ``RuntimeError`` in an update
(an indeterminate linear system, …) names the update, its time and the variable GTSAM names; so do a
non-finite estimate and a marginal covariance that is not positive definite (the stiffness rule reads it).
Final updates that leave a variable moving by more than ``final_tol`` after ``final_updates`` of them
(``final_updates=0`` asks for none) are an error unless the answer is converged relative to the problem all the
same (:func:`~.graph.converged`, the rule of :func:`~.graph.optimize`: the Gauss-Newton step from it below ``step_tol``
in its Mahalanobis norm, every variable within that fraction of its σ; on MRCLAM a heading wedged between 1 ms steps
keeps moving by 10⁻⁵ rad from update to update at ½χ² constant to 10⁻⁸, and on Dataset 1 robot 1 a variable by
4·10⁻⁴ at a step of 0.02 σ: research/notebook/2026-11-28-gtsam-convergence.md); a non-finite error at the end is
an error too.

Parameters: :class:`ISAM2SmootherParams` — the landmark smoothers' (:class:`~.landmark.LandmarkSmootherParams`),
iSAM2's relinearisation (:class:`~.graph.RelinearizationParams`), the final updates, the factorisation, the
stiffness rule's ε and the clock of ``step_time``.

``Estimate``: the final smoothed poses (one per key) and landmarks; covariances from
``ISAM2.marginalCovariance`` (poses converted to the world frame); with ``output="online"`` the poses are the
online estimates instead (``online_poses`` below, no pose covariances: iSAM2 does not compute the marginal of x_k at
step k), the landmarks still the final ones; ``step_time[k]`` = wall time
(``step_clock="cpu"``: CPU time) of update k plus reading x̂_k, like the filters' per-event time. ``diagnostics``:
``online_poses`` (K, 3) — the estimate of x_k right after step k (what a filter would have had),
``relinearized`` (K,) variables relinearised per step, ``final_updates_used``, ``final_change``,
``final_error``, ``lifted_between``, ``between_cov`` (K − 1, 3, 3) and the rejected-input counts; ``meta["params"]``
the canonical parameters.
"""

from __future__ import annotations

from typing import Literal

import gtsam
import numpy as np
from pydantic import NonNegativeInt, PositiveFloat

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose
from slamarena.datasets.sequence import Sequence
from slamarena.estimators.models import inverse_observe
from slamarena.estimators.stepping import CLOCKS, StepClock
from slamarena.params import Field

from .graph import (
    L,
    OptimizationError,
    RelinearizationParams,
    StepTol,
    X,
    converged,
    finite_error,
    gtsam_errors,
    isam2_params,
    landmark_step_factors,
    observation_noises,
    point_covariances,
    points_of,
    poses_of,
    range_noise,
    world_pose_covariances,
)
from .landmark import LandmarkSmoother, LandmarkSmootherParams
from .noise import floor_to_uncertainty
from .problem import LandmarkProblem

__all__ = ["ISAM2Smoother", "ISAM2SmootherParams"]


class ISAM2SmootherParams(LandmarkSmootherParams, RelinearizationParams):
    """Parameters of :class:`ISAM2Smoother`: the landmark smoothers', iSAM2's relinearisation and the final updates."""

    final_updates: NonNegativeInt = Field(
        10, description="most empty updates after the last step that relinearise and re-solve everything"
    )
    final_tol: PositiveFloat = Field(
        1e-6, description="the final updates stop once no variable changes by more than this in any coordinate [m, rad]"
    )
    step_tol: StepTol = 0.1
    factorization: Literal["CHOLESKY", "QR"] = Field(
        "CHOLESKY", description="iSAM2's factorisation of the linearised system"
    )
    step_clock: StepClock = Field(
        "wall", description="clock of step_time: wall time, or the process's CPU time (all threads) [s]"
    )
    output: Literal["smoothed", "online"] = Field(
        "smoothed",
        description="the Estimate's poses: the final smoothed ones, or each x̂_k right after step k (what a filter has)",
    )
    uncertainty_floor: float | None = Field(
        2.0**-22,
        gt=0.0,
        lt=1.0,
        description="ε of the stiffness rule: no between factor stiffer in any direction than ε times the "
        "uncertainty of the poses it joins (noise.floor_to_uncertainty) [1]; None: factors as given",
    )


class ISAM2Smoother(LandmarkSmoother):
    """The landmark graph grown one pose per iSAM2 update, then relinearised to the batch optimum (:class:`ISAM2SmootherParams`)."""

    Params = ISAM2SmootherParams

    def isam(self) -> gtsam.ISAM2:
        settings = isam2_params(self.params)
        settings.setFactorization(self.params.factorization)
        return gtsam.ISAM2(settings)

    def run(self, sequence: Sequence) -> Estimate:
        problem = self.problem(sequence)
        free = self.free_beacons(problem)
        if free.size:
            raise ValueError(
                f"{sequence.name}: beacons {free.tolist()} have ranges but no surveyed position (or beacon_prior_sigma is None); "
                "iSAM2 cannot initialise a beacon from one range — use gtsam_batch for range-only SLAM"
            )
        return self.solve(problem)

    def solve(self, problem: LandmarkProblem) -> Estimate:
        """The smoother on a problem whose ranged beacons are all anchored or observed (:meth:`run` checks that)."""
        K = problem.n_poses
        isam = self.isam()
        obs_noises = observation_noises(problem, self.params)
        rng_noise = range_noise(problem.R_range, self.params)
        known: set[int] = set()
        online = np.empty((K, 3))
        step_time = np.empty(K)
        relinearized = np.zeros(K, dtype=np.int64)
        between_cov = problem.cov.copy()
        lifted = 0
        eps = self.params.uncertainty_floor
        clock = CLOCKS[self.params.step_clock]
        for k, (rows, range_rows) in enumerate(zip(problem.observation_slices(), problem.range_slices())):
            tic = clock()
            where = f"iSAM2 update {k} (t = {problem.t[k]:.6g} s)"
            if k > 0 and eps is not None:
                with gtsam_errors(where):
                    previous = isam.marginalCovariance(X(k - 1))
                if not (np.isfinite(previous).all() and np.linalg.eigvalsh(previous)[0] > 0):
                    raise OptimizationError(
                        f"{where}: the marginal covariance of x{k - 1} is not positive definite (the estimate is diverging)"
                    )
                given = problem.cov[k - 1]
                C = floor_to_uncertainty(given, previous, problem.delta[k - 1], eps)
                lifted += C is not given
                between_cov[k - 1] = C
            factors = landmark_step_factors(
                problem, k, self.prior_cov, between_cov, obs_noises, rows, rng_noise, range_rows
            )
            values = gtsam.Values()
            x = problem.start if k == 0 else compose(online[k - 1], problem.delta[k - 1])
            values.insert(X(k), gtsam.Pose2(*x))
            for j, r, b in zip(problem.obs_id[rows], problem.obs_range[rows], problem.obs_bearing[rows]):
                if j not in known:
                    known.add(int(j))
                    values.insert(L(j), gtsam.Point2(*inverse_observe(x, (r, b))))
            for j in problem.rng_id[range_rows]:
                if j not in known:
                    known.add(int(j))
                    values.insert(L(j), gtsam.Point2(*problem.map_position(j)))
                    factors.add(self.beacon_prior(problem, j))
            with gtsam_errors(where):
                result = isam.update(factors, values)
                p = isam.calculateEstimatePose2(X(k))
            online[k] = (p.x(), p.y(), p.theta())
            step_time[k] = clock() - tic
            relinearized[k] = result.getVariablesRelinearized()
            if not np.isfinite(online[k]).all():
                raise OptimizationError(f"{where}: the estimate of x{k} is not finite")

        pose_keys = [X(k) for k in range(K)]
        ids = problem.landmark_ids
        landmark_keys = [L(j) for j in ids]
        estimate = isam.calculateEstimate()
        # final updates: relinearise every variable at each one and re-solve all of them (no wildfire cut-off)
        final = isam.params()
        final.setRelinearizeThreshold(0.0)
        final.relinearizeSkip = 1
        final.setOptimizationParams(gtsam.ISAM2GaussNewtonParams(0.0))
        used, change = 0, np.inf
        while used < self.params.final_updates and change > self.params.final_tol:
            with gtsam_errors(f"iSAM2 final update {used + 1}"):
                isam.update()
                refined = isam.calculateEstimate()
            used += 1
            change = _max_change(estimate, refined, pose_keys, landmark_keys)
            estimate = refined
        if self.params.final_updates and change > self.params.final_tol:
            # ran out: still the answer if it is converged relative to the problem (the rule of graph.optimize)
            done, remaining = converged(
                isam.getFactorsUnsafe(),
                estimate,
                f"iSAM2 after {used} final updates: the linearisation",
                self.params.step_tol,
            )
            if not done:
                raise OptimizationError(
                    f"iSAM2: the final updates did not converge, after {used} a variable still moved by {change:.3g} "
                    f"> final_tol = {self.params.final_tol:g} and the linearisation at the answer {remaining}; "
                    "raise final_updates"
                )
        final_error = finite_error(isam.getFactorsUnsafe(), estimate, f"iSAM2 after {used} final updates")
        poses = poses_of(estimate, pose_keys)
        landmarks = points_of(estimate, landmark_keys)
        pose_cov = landmark_cov = None
        if self.params.covariances:
            with gtsam_errors("iSAM2 marginal covariances"):
                pose_cov = world_pose_covariances(isam.marginalCovariance, pose_keys, poses)
                landmark_cov = point_covariances(isam.marginalCovariance, landmark_keys)
        diagnostics = {
            "online_poses": online,
            "relinearized": relinearized,
            "final_updates_used": used,
            "final_change": float(change),
            "final_error": final_error,
            "lifted_between": int(lifted),
            "between_cov": between_cov,
            **problem.counts,
        }
        if self.params.output == "online":
            poses, pose_cov = online, None
        return Estimate(
            method="gtsam_isam2",
            t=problem.t,
            poses=poses,
            pose_cov=pose_cov,
            landmark_ids=ids,
            landmarks=landmarks,
            landmark_cov=landmark_cov,
            step_time=step_time,
            diagnostics=diagnostics,
            meta={"params": self.params.canonical(), "poses": K, "landmarks": int(ids.size)},
        )


def _max_change(a, b, pose_keys, landmark_keys) -> float:
    """Largest change of any pose (via its tangent vector) or landmark coordinate between two Values."""
    dp = max((np.abs(a.atPose2(k).localCoordinates(b.atPose2(k))).max() for k in pose_keys), default=0.0)
    dl = max((np.abs(a.atPoint2(k) - b.atPoint2(k)).max() for k in landmark_keys), default=0.0)
    return float(max(dp, dl))
