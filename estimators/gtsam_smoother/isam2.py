"""Incremental landmark-SLAM smoother: the graph of :mod:`.landmark` grown one pose at a time with iSAM2.

Step k (one ``ISAM2.update`` per pose key): the between factor x_{k−1} → x_k (the prior at k = 0)
and pose k's bearing-range and beacon-range factors; new values: x_k = x̂_{k−1} ⊕ δ_k from the
current estimate, each new landmark from its first observation seen from that predicted pose, each
new beacon at its surveyed position with its prior (a single range cannot place a beacon: range-only
SLAM with free beacons needs delayed initialisation, which this smoother does not do — it raises
and points to the batch smoother). iSAM2 relinearises
variables whose update exceeds ``relinearize_threshold`` every ``relinearize_skip`` updates.

After the last step the relinearisation threshold, the skip and the wildfire threshold are set to
zero / one (``ISAM2.params()`` is the live parameter object), and up to ``final_updates`` empty
updates relinearise every variable and re-solve (Gauss-Newton iterations on the whole graph) until
the largest change of any variable is below ``final_tol``. The result then equals the batch
optimum to that tolerance (tested against :class:`~.batch.BatchSmoother`); without this the
answer would differ from the optimum by the linearisation error the threshold allows.

``Estimate``: the final smoothed poses (one per key) and landmarks; covariances from
``ISAM2.marginalCovariance`` (poses converted to the world frame); ``step_time[k]`` = wall time
(``step_clock="cpu"``: CPU time) of update k plus reading x̂_k, like the filters' per-event time. ``diagnostics``:
``online_poses`` (K, 3) — the estimate of x_k right after step k (what a filter would have had),
``relinearized`` (K,) variables relinearised per step, ``final_updates_used``, ``final_change``,
``final_error`` and the rejected-input counts.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import gtsam
import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose
from slamarena.datasets.sequence import Sequence
from slamarena.estimators.models import inverse_observe

from .graph import (L, X, check_choice, landmark_step_factors, observation_noise, point_covariances, points_of, poses_of, range_noise,
                    world_pose_covariances)
from .landmark import LandmarkSmootherConfig

__all__ = ["ISAM2Smoother"]

#: ``step_clock``: wall time (like the filters), or the process's CPU time (all threads), which other
#: processes on a shared machine disturb less (the benchmark uses it)
_CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


@dataclass(kw_only=True)
class ISAM2Smoother(LandmarkSmootherConfig):
    relinearize_threshold: float = 0.1
    relinearize_skip: int = 10
    final_updates: int = 10
    final_tol: float = 1e-6
    factorization: str = "CHOLESKY"
    step_clock: str = "wall"

    def __post_init__(self):
        super().__post_init__()
        if not self.relinearize_threshold >= 0 or self.relinearize_skip < 1 or self.final_updates < 0 or not self.final_tol > 0:
            raise ValueError("need relinearize_threshold ≥ 0, relinearize_skip ≥ 1, final_updates ≥ 0, final_tol > 0")
        check_choice("factorization", self.factorization, ("QR", "CHOLESKY"))
        check_choice("step_clock", self.step_clock, tuple(_CLOCKS))

    def isam(self) -> gtsam.ISAM2:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(float(self.relinearize_threshold))
        params.relinearizeSkip = int(self.relinearize_skip)
        params.setFactorization(self.factorization)
        return gtsam.ISAM2(params)

    def run(self, sequence: Sequence) -> Estimate:
        problem = self.problem(sequence)
        anchored = set(self.anchored_beacons(problem).tolist())
        free = sorted(set(problem.rng_id.tolist()) - anchored - set(problem.obs_id.tolist()))
        if free:
            raise ValueError(f"{sequence.name}: beacons {free} have ranges but no surveyed position (or beacon_prior_sigma is None); "
                             "iSAM2 cannot initialise a beacon from one range — use gtsam_batch for range-only SLAM")
        K = problem.n_poses
        isam = self.isam()
        obs_noise = observation_noise(problem.R, self.robust, self.robust_k)
        rng_noise = range_noise(problem.R_range, self.robust, self.robust_k)
        known: set[int] = set()
        online = np.empty((K, 3))
        step_time = np.empty(K)
        relinearized = np.zeros(K, dtype=np.int64)
        clock = _CLOCKS[self.step_clock]
        for k, (rows, range_rows) in enumerate(zip(problem.observation_slices(), problem.range_slices())):
            tic = clock()
            factors = landmark_step_factors(problem, k, self.prior_cov, obs_noise, rows, rng_noise, range_rows)
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
            result = isam.update(factors, values)
            p = isam.calculateEstimatePose2(X(k))
            online[k] = (p.x(), p.y(), p.theta())
            step_time[k] = clock() - tic
            relinearized[k] = result.getVariablesRelinearized()

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
        while used < self.final_updates and change > self.final_tol:
            isam.update()
            used += 1
            refined = isam.calculateEstimate()
            change = _max_change(estimate, refined, pose_keys, landmark_keys)
            estimate = refined
        poses = poses_of(estimate, pose_keys)
        landmarks = points_of(estimate, landmark_keys)
        pose_cov = landmark_cov = None
        if self.covariances:
            pose_cov = world_pose_covariances(isam.marginalCovariance, pose_keys, poses)
            landmark_cov = point_covariances(isam.marginalCovariance, landmark_keys)
        graph = isam.getFactorsUnsafe()
        diagnostics = {
            "online_poses": online,
            "relinearized": relinearized,
            "final_updates_used": used,
            "final_change": float(change),
            "final_error": float(graph.error(estimate)),
            **problem.counts,
        }
        return Estimate(
            method="gtsam_isam2", t=problem.t, poses=poses, pose_cov=pose_cov, landmark_ids=ids, landmarks=landmarks,
            landmark_cov=landmark_cov, step_time=step_time, diagnostics=diagnostics,
            meta={"relinearize_threshold": self.relinearize_threshold, "relinearize_skip": self.relinearize_skip,
                  "poses": K, "landmarks": int(ids.size)},
        )


def _max_change(a, b, pose_keys, landmark_keys) -> float:
    """Largest change of any pose (via its tangent vector) or landmark coordinate between two Values."""
    dp = max((np.abs(a.atPose2(k).localCoordinates(b.atPose2(k))).max() for k in pose_keys), default=0.0)
    dl = max((np.abs(a.atPoint2(k) - b.atPoint2(k)).max() for k in landmark_keys), default=0.0)
    return float(max(dp, dl))
