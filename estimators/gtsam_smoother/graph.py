"""GTSAM building blocks shared by the smoothers: keys, noise models, factors, optimisers, marginals.

Keys: pose k is ``x_k`` (``gtsam.symbol('x', k)``), landmark or beacon j is ``l_j``.

Noise models: ``Gaussian.Covariance(Σ)`` optionally wrapped in ``Robust`` with a Huber or Cauchy
m-estimator of width ``k`` (in units of the whitened error, i.e. standard deviations).

``BearingRangeFactor2D`` orders its measurement as (bearing, range); the datasets state the
observation noise in (range, bearing) order, so :func:`observation_noise` swaps it. Beacon ranges
are ``RangeFactor2D`` (‖l_j − p_k‖ = z − β); a beacon whose position is known is anchored by a
``PriorFactorPoint2``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import gtsam
import numpy as np

from .noise import body_to_world
from .problem import LandmarkProblem

__all__ = [
    "X", "L", "ROBUST", "OPTIMIZERS", "noise_model", "information_model", "robustify", "observation_noise", "range_noise", "landmark_step_factors",
    "optimize", "OptimizeResult", "poses_of", "points_of", "check_choice",
]

ROBUST = ("none", "huber", "cauchy")
OPTIMIZERS = ("lm", "gauss_newton", "dogleg")
_SWAP = np.array([[0.0, 1.0], [1.0, 0.0]])


def X(k: int) -> int:
    return gtsam.symbol("x", int(k))


def L(j: int) -> int:
    return gtsam.symbol("l", int(j))


def check_choice(name: str, value: str, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")


def noise_model(cov: np.ndarray, robust: str = "none", k: float = 1.345):
    """Gaussian noise with covariance ``cov``, optionally robustified (Huber/Cauchy, width k)."""
    return robustify(gtsam.noiseModel.Gaussian.Covariance(np.asarray(cov, dtype=float)), robust, k)


def information_model(information: np.ndarray, robust: str = "none", k: float = 1.345):
    """Gaussian noise with information matrix ``information``, optionally robustified."""
    return robustify(gtsam.noiseModel.Gaussian.Information(np.asarray(information, dtype=float)), robust, k)


def robustify(base, robust: str, k: float):
    """``base`` wrapped in a Huber or Cauchy m-estimator of width k (``robust="none"``: unchanged)."""
    if robust == "none":
        return base
    estimator = {"huber": gtsam.noiseModel.mEstimator.Huber, "cauchy": gtsam.noiseModel.mEstimator.Cauchy}[robust]
    return gtsam.noiseModel.Robust.Create(estimator.Create(k), base)


def observation_noise(R: np.ndarray, robust: str = "none", k: float = 1.345):
    """Noise of a ``BearingRangeFactor2D`` from the (range, bearing) covariance R."""
    return noise_model(_SWAP @ R @ _SWAP, robust, k)


def range_noise(variance: float, robust: str = "none", k: float = 1.345):
    """Noise of a ``RangeFactor2D``: one range of the given variance [m²]."""
    return robustify(gtsam.noiseModel.Isotropic.Variance(1, float(variance)), robust, k)


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


def optimize(graph, initial, *, optimizer: str = "lm", max_iterations: int = 100, relative_error_tol: float = 1e-10,
             absolute_error_tol: float = 1e-10) -> OptimizeResult:
    """Batch nonlinear least squares with Levenberg-Marquardt, Gauss-Newton or Dogleg."""
    check_choice("optimizer", optimizer, OPTIMIZERS)
    params_cls, optimizer_cls = {
        "lm": (gtsam.LevenbergMarquardtParams, gtsam.LevenbergMarquardtOptimizer),
        "gauss_newton": (gtsam.GaussNewtonParams, gtsam.GaussNewtonOptimizer),
        "dogleg": (gtsam.DoglegParams, gtsam.DoglegOptimizer),
    }[optimizer]
    params = params_cls()
    params.setMaxIterations(int(max_iterations))
    params.setRelativeErrorTol(float(relative_error_tol))
    params.setAbsoluteErrorTol(float(absolute_error_tol))
    initial_error = graph.error(initial)
    tic = time.perf_counter()
    opt = optimizer_cls(graph, initial, params)
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
