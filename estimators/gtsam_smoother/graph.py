"""GTSAM building blocks shared by the smoothers: keys, noise models, factors, optimisers, marginals.

Keys: pose k is ``x_k`` (``gtsam.symbol('x', k)``), landmark or beacon j is ``l_j``.

Noise models: ``Gaussian.Covariance(Σ)`` optionally wrapped in ``Robust`` with a Huber or Cauchy
m-estimator (:mod:`slamarena.robust`: :class:`RobustKernelParams`, shared by every smoother and by laser
graph SLAM's back end).

``BearingRangeFactor2D`` orders its measurement as (bearing, range); the datasets state the
observation noise in (range, bearing) order, so :func:`observation_noise` swaps it. Beacon ranges
are ``RangeFactor2D`` (‖l_j − p_k‖ = z − β); a beacon whose position is known is anchored by a
``PriorFactorPoint2``.

Settings shared by several smoothers: :class:`OptimizerParams` (batch nonlinear least squares:
the batch smoother and the pose-graph optimiser), :class:`RelinearizationParams` (iSAM2: the
incremental and the fixed-lag smoother).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Annotated, Literal

import gtsam
import numpy as np
from pydantic import NonNegativeFloat, PositiveInt

from slamarena.params import Field, Params
from slamarena.robust import RobustKernelParams, information_model, noise_model, robustify

from .noise import body_to_world
from .problem import LandmarkProblem

__all__ = [
    "X", "L", "RobustKernelParams", "OptimizerParams", "RelinearizationParams", "RelativeErrorTol", "AbsoluteErrorTol",
    "RelinearizeSkip", "ComputeCovariances", "noise_model", "information_model", "robustify", "observation_noise",
    "range_noise", "landmark_step_factors", "isam2_params", "optimize", "OptimizeResult", "poses_of", "points_of",
]

_SWAP = np.array([[0.0, 1.0], [1.0, 0.0]])

#: field types whose default differs between the models that share them (one description, one rule each)
RelativeErrorTol = Annotated[NonNegativeFloat, Field(description="stop when the error's relative decrease in one iteration is below this [1]")]
AbsoluteErrorTol = Annotated[NonNegativeFloat, Field(description="stop when the error's decrease in one iteration is below this [½ χ²]")]
RelinearizeSkip = Annotated[PositiveInt, Field(description="iSAM2 checks which variables to relinearise every this many updates")]
ComputeCovariances = Annotated[bool, Field(description="compute the marginal covariances: world-frame pose_cov and landmark_cov")]


class OptimizerParams(Params):
    """Batch nonlinear least squares (:func:`optimize`)."""

    optimizer: Literal["lm", "gauss_newton", "dogleg"] = Field("lm", description="Levenberg-Marquardt, Gauss-Newton or Powell's Dogleg")
    max_iterations: PositiveInt = Field(100, description="most iterations of the optimiser")
    relative_error_tol: RelativeErrorTol = 1e-10
    absolute_error_tol: AbsoluteErrorTol = 1e-10


class RelinearizationParams(Params):
    """iSAM2's relinearisation (:func:`isam2_params`)."""

    relinearize_threshold: NonNegativeFloat = Field(
        0.1, description="iSAM2 relinearises a variable whose linear update exceeds this in any tangent coordinate [m, rad]")
    relinearize_skip: RelinearizeSkip = 10


def X(k: int) -> int:
    return gtsam.symbol("x", int(k))


def L(j: int) -> int:
    return gtsam.symbol("l", int(j))


def observation_noise(R: np.ndarray, kernel: RobustKernelParams | None = None):
    """Noise of a ``BearingRangeFactor2D`` from the (range, bearing) covariance R."""
    return noise_model(_SWAP @ R @ _SWAP, kernel)


def range_noise(variance: float, kernel: RobustKernelParams | None = None):
    """Noise of a ``RangeFactor2D``: one range of the given variance [m²]."""
    return robustify(gtsam.noiseModel.Isotropic.Variance(1, float(variance)), kernel)


def landmark_step_factors(problem: LandmarkProblem, k: int, prior_cov: np.ndarray, obs_noise, rows: slice,
                          rng_noise=None, range_rows: slice = slice(0, 0)) -> gtsam.NonlinearFactorGraph:
    """Factors added with pose k: the prior (k = 0) or the between factor k−1 → k, pose k's observations
    and its beacon ranges."""
    graph = gtsam.NonlinearFactorGraph()
    if k == 0:
        graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(*problem.start), noise_model(prior_cov)))
    else:
        graph.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), gtsam.Pose2(*problem.delta[k - 1]), noise_model(problem.cov[k - 1])))
    for j, r, b in zip(problem.obs_id[rows], problem.obs_range[rows], problem.obs_bearing[rows]):
        graph.add(gtsam.BearingRangeFactor2D(X(k), L(j), gtsam.Rot2(float(b)), float(r), obs_noise))
    for j, r in zip(problem.rng_id[range_rows], problem.rng_range[range_rows]):
        graph.add(gtsam.RangeFactor2D(X(k), L(j), float(r), rng_noise))
    return graph


@dataclass
class OptimizeResult:
    values: "gtsam.Values"
    initial_error: float
    final_error: float
    iterations: int
    time_s: float


def isam2_params(params: RelinearizationParams) -> gtsam.ISAM2Params:
    """GTSAM's iSAM2 parameters with the given relinearisation (everything else GTSAM's defaults)."""
    isam2 = gtsam.ISAM2Params()
    isam2.setRelinearizeThreshold(float(params.relinearize_threshold))
    isam2.relinearizeSkip = int(params.relinearize_skip)
    return isam2


def optimize(graph, initial, params: OptimizerParams) -> OptimizeResult:
    """Batch nonlinear least squares with Levenberg-Marquardt, Gauss-Newton or Dogleg."""
    settings_cls, optimizer_cls = {
        "lm": (gtsam.LevenbergMarquardtParams, gtsam.LevenbergMarquardtOptimizer),
        "gauss_newton": (gtsam.GaussNewtonParams, gtsam.GaussNewtonOptimizer),
        "dogleg": (gtsam.DoglegParams, gtsam.DoglegOptimizer),
    }[params.optimizer]
    settings = settings_cls()
    settings.setMaxIterations(int(params.max_iterations))
    settings.setRelativeErrorTol(float(params.relative_error_tol))
    settings.setAbsoluteErrorTol(float(params.absolute_error_tol))
    initial_error = graph.error(initial)
    tic = time.perf_counter()
    opt = optimizer_cls(graph, initial, settings)
    values = opt.optimize()
    elapsed = time.perf_counter() - tic
    return OptimizeResult(values, float(initial_error), float(graph.error(values)), int(opt.iterations()), elapsed)


def poses_of(values, keys) -> np.ndarray:
    """Poses (K, 3) of the given pose keys."""
    out = np.empty((len(keys), 3))
    for i, key in enumerate(keys):
        p = values.atPose2(key)
        out[i] = (p.x(), p.y(), p.theta())
    return out


def points_of(values, keys) -> np.ndarray:
    """Points (L, 2) of the given landmark keys."""
    return np.array([values.atPoint2(key) for key in keys], dtype=float).reshape(-1, 2)


def world_pose_covariances(marginal, keys, poses: np.ndarray) -> np.ndarray:
    """World-frame (x, y, θ) covariances (K, 3, 3) from a ``marginal(key)`` giving GTSAM's body-frame Σ."""
    body = np.array([marginal(key) for key in keys], dtype=float).reshape(-1, 3, 3)
    return body_to_world(poses[:, 2], body)


def point_covariances(marginal, keys) -> np.ndarray:
    """Landmark covariances (L, 2, 2); a Point2's tangent space is the world frame already."""
    return np.array([marginal(key) for key in keys], dtype=float).reshape(-1, 2, 2)
