"""Batch landmark-SLAM smoother: the whole graph of :mod:`.landmark` optimised at once.

Initial values: the dead-reckoned poses, each landmark from its first observation; beacons
(range-only) at their surveyed position when anchored, else trilaterated from the dead-reckoned
poses (range-only SLAM: the answer depends on that start; ``diagnostics["beacons_anchored"]``). Optimiser:
Levenberg-Marquardt (default), Gauss-Newton or Dogleg. Covariances from ``gtsam.Marginals``
(body frame → world frame for poses).

Parameters: :class:`BatchSmootherParams` — the landmark smoothers' (:class:`~.landmark.LandmarkSmootherParams`)
and the optimiser's (:class:`~.graph.OptimizerParams`).

``Estimate``: one pose per pose key (``t`` = key times), world-frame ``pose_cov``, landmarks with
covariances; ``step_time`` is ``None`` (a batch method has no per-step cost; the total times are
in ``diagnostics``: ``time_optimize``, ``time_marginals``), plus ``initial_error``,
``final_error`` (½ Σ‖e‖²), ``iterations`` and the rejected-input counts (:mod:`.problem`); ``meta["params"]`` the
canonical parameters. An optimisation that does not converge, and a failure of GTSAM's marginals, is
:class:`~.graph.OptimizationError` (:func:`~.graph.optimize`), never a result.
"""
from __future__ import annotations

import time

import gtsam

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sequence import Sequence

from .graph import (L, OptimizerParams, X, gtsam_errors, landmark_step_factors, observation_noise, optimize, point_covariances, points_of,
                    poses_of, range_noise, world_pose_covariances)
from .landmark import LandmarkSmoother, LandmarkSmootherParams
from .problem import LandmarkProblem

__all__ = ["BatchSmoother", "BatchSmootherParams"]


class BatchSmootherParams(LandmarkSmootherParams, OptimizerParams):
    """Parameters of :class:`BatchSmoother`: the landmark smoothers' and the optimiser's."""


class BatchSmoother(LandmarkSmoother):
    """The whole landmark graph optimised at once (:class:`BatchSmootherParams`)."""

    Params = BatchSmootherParams

    def graph(self, problem: LandmarkProblem) -> gtsam.NonlinearFactorGraph:
        graph = gtsam.NonlinearFactorGraph()
        obs_noise = observation_noise(problem.R, self.params)
        rng_noise = range_noise(problem.R_range, self.params)
        for k, (rows, range_rows) in enumerate(zip(problem.observation_slices(), problem.range_slices())):
            graph.push_back(landmark_step_factors(problem, k, self.prior_cov, obs_noise, rows, rng_noise, range_rows))
        for j in self.anchored_beacons(problem):
            graph.add(self.beacon_prior(problem, j))
        return graph

    def initial_values(self, problem: LandmarkProblem) -> gtsam.Values:
        values = gtsam.Values()
        poses = problem.dead_reckoning()
        for k, p in enumerate(poses):
            values.insert(X(k), gtsam.Pose2(*p))
        anchored = self.anchored_beacons(problem)
        beacon_ids, beacon_xy = problem.trilaterate(poses)
        for j, m in zip(beacon_ids, beacon_xy):
            values.insert(L(j), gtsam.Point2(*(problem.map_position(j) if j in anchored else m)))
        for j, m in zip(*problem.first_sightings(poses)):
            if values.exists(L(j)):
                values.update(L(j), gtsam.Point2(*m))
            else:
                values.insert(L(j), gtsam.Point2(*m))
        return values

    def run(self, sequence: Sequence) -> Estimate:
        problem = self.problem(sequence)
        graph = self.graph(problem)
        result = optimize(graph, self.initial_values(problem), self.params)
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
            "time_optimize": result.time_s,
            "time_marginals": time.perf_counter() - tic,
            "beacons_anchored": int(self.anchored_beacons(problem).size),
            **problem.counts,
        }
        return Estimate(
            method="gtsam_batch", t=problem.t, poses=poses, pose_cov=pose_cov, landmark_ids=ids, landmarks=landmarks,
            landmark_cov=landmark_cov, diagnostics=diagnostics,
            meta={"params": self.params.canonical(), "factors": int(graph.size()), "poses": problem.n_poses, "landmarks": int(ids.size)},
        )
