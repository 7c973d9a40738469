"""Fixed-lag localization smoother: the factor-graph counterpart of the EKF localizer.

Graph over the poses x_k ∈ SE(2) at the start, the end, and every GPS or IMU stamp::

    PriorFactorPose2        x_0 ~ start pose (σ = prior_sigma)
    BetweenFactorPose2      x_{k−1}⁻¹ x_k ≈ δ_k, Σ_k = Jᵀ P_δ J        cmd_vel pieces through the motion
                                                                      model, P_δ = Σ G·VMVᵀ·Gᵀ (as the EKF)
    PoseTranslationPrior2D  t(x_k) = z_gps + v,  v ~ N(0, R_gps)      world-frame (x, y) (2×2)
    PoseRotationPrior2D     θ(x_k) = z_yaw ⊖ w,  w ~ N(0, R_imu)      wrapped angle error (1×1)

The same inputs and noise as the EKF localizer run with the sequence's noise
(``use_sequence_noise=True``): M = ``Noise.twist_cov``, R_gps = ``Noise.gps_cov``,
R_imu = ``Noise.yaw_var`` (each can be overridden). GTSAM's ``IncrementalFixedLagSmoother``
(iSAM2 inside) keeps the poses of the last ``lag`` seconds and marginalises older ones into a
prior on the window. A robust kernel (``robust``) can be put on the GPS factors for outliers.

Bad input is rejected and counted before it reaches the graph: GPS fixes and yaw readings that are not
finite or too large to square (``rejected_nonfinite_gps``, ``rejected_nonfinite_heading``), and the motion
rows as in :mod:`.problem`. GTSAM's ``RuntimeError`` in an update (an indeterminate linear system, …) and
a non-finite pose estimate are :class:`~.graph.OptimizationError` naming the update, its time and the
variable.

Parameters: :class:`FixedLagLocalizerParams` — the pose chain's (:class:`~.problem.PoseChainParams`, with
the EKF localizer's Euler model as default), the robust kernel (:class:`~.graph.RobustKernelParams`),
iSAM2's relinearisation (:class:`~.graph.RelinearizationParams`, every update by default), the lag, the
output and the GPS / IMU noise overrides.

``Estimate`` (one pose per key, world-frame ``pose_cov`` from ``marginalCovariance``):
``output="smoothed"`` — each pose as estimated just before it leaves the window (it has seen
``lag`` seconds of later data; the last window at the end of the run); ``output="online"`` —
each pose right after its own update (what a filter reports). ``diagnostics`` hold the other
trajectory (without covariances) as ``online_poses`` / ``smoothed_poses``, and the
rejected-input counts; ``meta["params"]`` the canonical parameters. ``step_time[k]`` =
wall time of update k.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Literal

import gtsam
import numpy as np
from pydantic import NonNegativeFloat, PositiveFloat

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose
from slamarena.datasets.sequence import Sequence
from slamarena.estimators.models import noise_in_force
from slamarena.params import Covariance2, Field

from .graph import (
    OptimizationError,
    RelinearizationParams,
    RelinearizeSkip,
    RobustKernelParams,
    gtsam_errors,
    isam2_params,
    noise_model,
    symbols,
)
from .noise import body_to_world
from .problem import MotionModelName, PoseChainParams, check_covariance, motion_chain, summable

__all__ = ["FixedLagLocalizer", "FixedLagLocalizerParams"]


class FixedLagLocalizerParams(PoseChainParams, RobustKernelParams, RelinearizationParams):
    """Parameters of :class:`FixedLagLocalizer`: the pose chain's, the robust kernel on the GPS factors, iSAM2's
    relinearisation, the lag, the output and the GPS / IMU noise."""

    motion_model: MotionModelName = "euler"
    relinearize_skip: RelinearizeSkip = 1
    lag: PositiveFloat = Field(
        2.0, description="poses older than this behind the newest are marginalised out of the window [s]"
    )
    output: Literal["smoothed", "online"] = Field(
        "smoothed",
        description="each pose as it leaves the window (seen lag seconds of later data) or right after its own update",
    )
    gps_cov: Covariance2 | None = Field(
        None, description="covariance of one GPS fix (x, y) [m²]; None: the sequence's Noise.gps_cov"
    )
    yaw_var: NonNegativeFloat | None = Field(
        None, description="variance of one IMU yaw [rad²]; None: the sequence's Noise.yaw_var"
    )


class FixedLagLocalizer:
    """cmd_vel + GPS + IMU yaw in GTSAM's IncrementalFixedLagSmoother (:class:`FixedLagLocalizerParams`)."""

    Params = FixedLagLocalizerParams

    def __init__(self, params: FixedLagLocalizerParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.prior_cov = np.diag(np.square(self.params.prior_sigma))

    def run(self, sequence: Sequence) -> Estimate:
        counts: dict = {}
        gps, heading = sequence.gps, sequence.heading
        stamps = []
        if gps is not None and len(gps):
            R_gps = check_covariance(
                "gps_cov", noise_in_force(self.params.gps_cov, sequence, "gps_cov", required=True), (2, 2)
            )
            ok = summable(gps.xy)
            counts["rejected_nonfinite_gps"] = int((~ok).sum())
            gps = gps.select(ok)
            stamps.append(gps.t)
        else:
            gps = None
        if heading is not None and len(heading):
            R_imu = check_covariance(
                "yaw_var",
                np.atleast_2d(float(noise_in_force(self.params.yaw_var, sequence, "yaw_var", required=True))),
                (1, 1),
            )
            ok = summable(heading.yaw)
            counts["rejected_nonfinite_heading"] = int((~ok).sum())
            heading = heading.select(ok)
            stamps.append(heading.t)
        else:
            heading = None
        chain = motion_chain(sequence, np.concatenate(stamps) if stamps else np.zeros(0), self.params)
        counts.update(chain.counts)
        K = chain.t.size
        gps_rows = _rows_per_pose(chain, gps.t if gps is not None else np.zeros(0), K, counts, "gps")
        yaw_rows = _rows_per_pose(chain, heading.t if heading is not None else np.zeros(0), K, counts, "heading")

        lag = self.params.lag
        smoother = gtsam.IncrementalFixedLagSmoother(lag, isam2_params(self.params))
        gps_noise = noise_model(R_gps, self.params) if gps is not None else None
        yaw_noise = noise_model(R_imu) if heading is not None else None
        keys = symbols("x", range(K))
        online = np.empty((K, 3))
        smoothed = np.empty((K, 3))
        body_cov = np.full((K, 3, 3), np.nan)  # GTSAM's body-frame marginal of each pose, for the output's trajectory
        step_time = np.empty(K)
        smoothed_out = self.params.output == "smoothed"
        window: deque[int] = deque()
        for k in range(K):
            tic = time.perf_counter()
            where = f"fixed-lag update {k} (t = {chain.t[k]:.6g} s)"
            # poses that this update will marginalise (timestamp < t_k − lag): read them while they are in the window
            while window and chain.t[window[0]] < chain.t[k] - lag:
                j = window.popleft()
                smoothed[j] = _pose(smoother, keys[j], j, body_cov if smoothed_out else None, where)
            factors = gtsam.NonlinearFactorGraph()
            if k == 0:
                factors.add(gtsam.PriorFactorPose2(keys[0], gtsam.Pose2(*chain.start), noise_model(self.prior_cov)))
                x = chain.start
            else:
                factors.add(
                    gtsam.BetweenFactorPose2(
                        keys[k - 1], keys[k], gtsam.Pose2(*chain.delta[k - 1]), noise_model(chain.cov[k - 1])
                    )
                )
                x = compose(online[k - 1], chain.delta[k - 1])
            for r in gps_rows[k]:
                factors.add(gtsam.PoseTranslationPrior2D(keys[k], gps.xy[r], gps_noise))
            for r in yaw_rows[k]:
                factors.add(gtsam.PoseRotationPrior2D(keys[k], gtsam.Rot2(float(heading.yaw[r])), yaw_noise))
            values = gtsam.Values()
            values.insert(keys[k], gtsam.Pose2(*x))
            with gtsam_errors(where):
                smoother.update(factors, values, {keys[k]: float(chain.t[k])})
            online[k] = _pose(smoother, keys[k], k, None if smoothed_out else body_cov, where)
            window.append(k)
            step_time[k] = time.perf_counter() - tic
        for j in window:
            smoothed[j] = _pose(smoother, keys[j], j, body_cov if smoothed_out else None, "fixed-lag end of the run")
        poses, other = (smoothed, {"online_poses": online}) if smoothed_out else (online, {"smoothed_poses": smoothed})
        cov = body_to_world(poses[:, 2], body_cov)
        return Estimate(
            method="gtsam_fixed_lag",
            t=chain.t,
            poses=poses,
            pose_cov=cov,
            step_time=step_time,
            diagnostics={**other, **counts},
            meta={"params": self.params.canonical(), "poses": K},
        )


def _rows_per_pose(chain, t: np.ndarray, K: int, counts: dict, name: str) -> list[np.ndarray]:
    """Measurement rows attached to each pose key (those outside the motion's span are counted and skipped)."""
    snapped, inside = chain.inside(t)
    counts[f"skipped_{name}_outside_motion"] = int((~inside).sum())
    rows = np.flatnonzero(inside)
    pose = chain.index(snapped[rows])
    bounds = np.searchsorted(pose, np.arange(K + 1))
    return [rows[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def _pose(smoother, key: int, k: int, body_cov: np.ndarray | None, where: str) -> np.ndarray:
    """Current estimate of pose k (its ``key``) and, into ``body_cov[k]`` unless None, its marginal covariance (GTSAM's
    body frame); :class:`OptimizationError` naming ``where`` if GTSAM fails or the pose is not finite."""
    with gtsam_errors(where):
        p = smoother.calculateEstimatePose2(key)
        pose = np.array([p.x(), p.y(), p.theta()])
        if body_cov is not None:
            body_cov[k] = smoother.marginalCovariance(key)
    if not np.isfinite(pose).all():
        raise OptimizationError(f"{where}: the estimate of x{k} is not finite")
    return pose
