"""Batch landmark-SLAM smoother: the whole graph of :mod:`.landmark` optimised at once.

Initial values (``initial``): ``"isam2"`` (default) — iSAM2's estimate (:class:`~.isam2.ISAM2Smoother` with the same
landmark-smoother parameters, no final updates, no marginals) of every pose and every landmark or beacon it can start
(free beacons' ranges left out); ``"dead_reckoning"`` — the dead-reckoned poses, each landmark from its first
observation at those poses and anchored beacons at their surveyed positions. Free beacons (range-only SLAM) start
trilaterated from the initial poses (:meth:`~.problem.LandmarkProblem.trilaterate`: the answer depends on that start;
``diagnostics["beacons_anchored"]``). Levenberg-Marquardt is a local method: from dead reckoning the heading drift of
the whole run has placed the landmarks where it stops in a local minimum (MRCLAM Dataset 6 robot 3: ½χ² 24 978
against 2 899) or gives up (Victoria Park); from iSAM2's estimate, whose initial values come step by step from the
current estimate, it reaches the optimum (research/method/graph_slam.md has the measurements and the alternatives tried).
iSAM2 is incremental Gauss-Newton without damping: a gross outlier it cannot down-weight can make it diverge where
Levenberg-Marquardt from dead reckoning copes (§1b); its failure is the batch smoother's OptimizationError, naming the start.
Optimiser: Levenberg-Marquardt (default), Gauss-Newton or Dogleg. Covariances from ``gtsam.Marginals`` (body frame →
world frame for poses).

The between factors' covariances are the problem's, or those given to :meth:`BatchSmoother.run` as ``between_cov``
(iSAM2's ``diagnostics["between_cov"]``, lifted by its stiffness rule: the graph iSAM2 solved, whose optimum iSAM2's
answer must equal).

Parameters: :class:`BatchSmootherParams` — the landmark smoothers' (:class:`~.landmark.LandmarkSmootherParams`),
the optimiser's (:class:`~.graph.OptimizerParams`) and ``initial``.

``Estimate``: one pose per pose key (``t`` = key times), world-frame ``pose_cov``, landmarks with
covariances; ``step_time`` is ``None`` (a batch method has no per-step cost; the total times are
in ``diagnostics``: ``time_initial`` (iSAM2's start), ``time_optimize``, ``time_marginals``), plus ``initial_error`` (½ Σ‖e‖² at the initial
values), ``final_error`` (at the optimum), ``iterations`` and the rejected-input counts (:mod:`.problem`); ``meta["params"]`` the
canonical parameters. An optimisation that does not converge, and a failure of GTSAM's marginals, is
:class:`~.graph.OptimizationError` (:func:`~.graph.optimize`), never a result.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Literal

import gtsam
import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sequence import Sequence
from slamarena.params import Field

from .graph import (
    L,
    OptimizationError,
    OptimizerParams,
    X,
    gtsam_errors,
    landmark_step_factors,
    observation_noises,
    optimize,
    point_covariances,
    points_of,
    poses_of,
    range_noise,
    world_pose_covariances,
)
from .isam2 import ISAM2Smoother
from .landmark import LandmarkSmoother, LandmarkSmootherParams
from .problem import LandmarkProblem, valid_covariances

__all__ = ["BatchSmoother", "BatchSmootherParams"]


class BatchSmootherParams(LandmarkSmootherParams, OptimizerParams):
    """Parameters of :class:`BatchSmoother`: the landmark smoothers', the optimiser's and the initial values."""

    initial: Literal["isam2", "dead_reckoning"] = Field(
        "isam2",
        description="initial values: iSAM2's estimate (no final updates), or dead reckoning with each landmark from its "
        "first observation",
    )


class BatchSmoother(LandmarkSmoother):
    """The whole landmark graph optimised at once (:class:`BatchSmootherParams`)."""

    Params = BatchSmootherParams

    def graph(self, problem: LandmarkProblem, between_cov: np.ndarray) -> gtsam.NonlinearFactorGraph:
        graph = gtsam.NonlinearFactorGraph()
        obs_noises = observation_noises(problem, self.params)
        rng_noise = range_noise(problem.R_range, self.params)
        for k, (rows, range_rows) in enumerate(zip(problem.observation_slices(), problem.range_slices())):
            landmark_step_factors(
                problem, k, self.prior_cov, between_cov, obs_noises, rows, rng_noise, range_rows, graph
            )
        for j in self.anchored_beacons(problem):
            graph.add(self.beacon_prior(problem, j))
        return graph

    def initial_values(self, problem: LandmarkProblem) -> gtsam.Values:
        """Poses and landmarks to start from (module docstring)."""
        if self.params.initial == "isam2":
            start = self.isam2_start(problem)
            poses, known = start.poses, dict(zip(start.landmark_ids.tolist(), start.landmarks))
        else:
            poses = problem.dead_reckoning()
            known = {j: problem.map_position(j) for j in self.anchored_beacons(problem).tolist()}
            known.update(zip(*problem.first_sightings(poses)))
        beacon_ids, beacon_xy = problem.trilaterate(poses)
        known = {**dict(zip(beacon_ids.tolist(), beacon_xy)), **known}  # trilaterated: the free beacons
        values = gtsam.Values()
        for k, p in enumerate(poses):
            values.insert(X(k), gtsam.Pose2(*p))
        for j in problem.landmark_ids.tolist():
            values.insert(L(j), gtsam.Point2(*known[j]))
        return values

    def isam2_start(self, problem: LandmarkProblem) -> Estimate:
        """iSAM2's estimate without final updates and marginals, on the problem without the free beacons' ranges."""
        keep = ~np.isin(problem.rng_id, self.free_beacons(problem))
        startable = dataclasses.replace(
            problem, rng_pose=problem.rng_pose[keep], rng_id=problem.rng_id[keep], rng_range=problem.rng_range[keep]
        )
        shared = {name: getattr(self.params, name) for name in LandmarkSmootherParams.model_fields}
        try:
            return ISAM2Smoother(**{**shared, "covariances": False, "final_updates": 0}).solve(startable)
        except OptimizationError as exc:
            raise OptimizationError(
                f"the batch smoother's start (initial='isam2'): {exc}; initial='dead_reckoning' starts from dead "
                "reckoning"
            ) from exc

    def run(self, sequence: Sequence, between_cov: np.ndarray | None = None) -> Estimate:
        """The optimum of the sequence's graph; ``between_cov`` (K − 1, 3, 3) replaces the between factors' covariances
        (``ValueError`` unless one positive-definite covariance per step of the sequence's problem)."""
        problem = self.problem(sequence)
        graph = self.graph(problem, problem.cov if between_cov is None else _checked_between(between_cov, problem))
        tic = time.perf_counter()
        initial = self.initial_values(problem)
        time_initial = time.perf_counter() - tic
        result = optimize(graph, initial, self.params)
        pose_keys = [X(k) for k in range(problem.n_poses)]
        ids = problem.landmark_ids
        landmark_keys = [L(j) for j in ids]
        poses = poses_of(result.values, pose_keys)
        landmarks = points_of(result.values, landmark_keys)
        pose_cov = landmark_cov = None
        tic = time.perf_counter()
        if self.params.covariances:
            with gtsam_errors("marginal covariances"):
                marginals = gtsam.Marginals(graph, result.values)
                pose_cov = world_pose_covariances(marginals.marginalCovariance, pose_keys, poses)
                landmark_cov = point_covariances(marginals.marginalCovariance, landmark_keys)
        diagnostics = {
            "initial_error": result.initial_error,
            "final_error": result.final_error,
            "iterations": result.iterations,
            "time_initial": time_initial,
            "time_optimize": result.time_s,
            "time_marginals": time.perf_counter() - tic,
            "beacons_anchored": int(self.anchored_beacons(problem).size),
            **problem.counts,
        }
        return Estimate(
            method="gtsam_batch",
            t=problem.t,
            poses=poses,
            pose_cov=pose_cov,
            landmark_ids=ids,
            landmarks=landmarks,
            landmark_cov=landmark_cov,
            diagnostics=diagnostics,
            meta={
                "params": self.params.canonical(),
                "factors": int(graph.size()),
                "poses": problem.n_poses,
                "landmarks": int(ids.size),
            },
        )


def _checked_between(between_cov, problem: LandmarkProblem) -> np.ndarray:
    C = np.asarray(between_cov, dtype=float)
    if C.shape != problem.cov.shape:
        raise ValueError(
            f"between_cov must have shape {problem.cov.shape} (one 3×3 covariance per step of the problem), got {C.shape}"
        )
    positive = valid_covariances(C)
    positive[positive] = np.linalg.eigvalsh(C[positive])[:, 0] > 0
    bad = np.flatnonzero(~positive)
    if bad.size:
        raise ValueError(f"between_cov[{bad[0]}] (and {bad.size - 1} more) is not a positive-definite covariance")
    return C
