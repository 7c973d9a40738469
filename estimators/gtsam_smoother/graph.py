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

Failures: :func:`optimize` returns only an optimum. It raises :class:`OptimizationError` when the error
at the initial values or at the end is not finite (naming the first factor whose error is not), when
it ended above where it started, and when the optimiser stopped without converging — Levenberg-Marquardt
gave up (no damping up to ``lambdaUpperBound`` lowers the error: GTSAM's "cannot decrease error with
maximum lambda"), the last iteration raised the error by more than the tolerances (Gauss-Newton
diverging: GTSAM's "stopping because error increased"), or ``max_iterations`` ran out with the last
decrease above the tolerances — unless the answer is converged relative to the problem all the same
(:func:`converged`): the Gauss-Newton step δ from it to the optimum of its own linearisation is below ``step_tol``
(default 0.1) in its Mahalanobis norm, so every variable and every linear function of them lies within that fraction
of its own marginal σ of that optimum (Levenberg-Marquardt crawls or gives up there when the tolerances ask for
more than round-off and conditioning allow). Inside :func:`gtsam_errors`, GTSAM's own
``RuntimeError`` (an indeterminate linear system, …) becomes an :class:`OptimizationError` that says
where it happened and which variable GTSAM names.
"""

from __future__ import annotations

import re
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Annotated, Literal

import gtsam
import numpy as np
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt

from slamarena.params import Field, Params
from slamarena.robust import RobustKernelParams, information_model, noise_model, robustify

from .noise import body_to_world
from .problem import LandmarkProblem

__all__ = [
    "X",
    "L",
    "symbols",
    "information_models",
    "RobustKernelParams",
    "OptimizerParams",
    "RelinearizationParams",
    "RelativeErrorTol",
    "AbsoluteErrorTol",
    "RelinearizeSkip",
    "ComputeCovariances",
    "noise_model",
    "information_model",
    "robustify",
    "observation_noise",
    "range_noise",
    "observation_noises",
    "landmark_step_factors",
    "isam2_params",
    "optimize",
    "OptimizeResult",
    "OptimizationError",
    "gtsam_errors",
    "finite_error",
    "remaining_decrease",
    "converged",
    "StepTol",
    "poses_of",
    "points_of",
]

_SWAP = np.array([[0.0, 1.0], [1.0, 0.0]])

#: field types whose default differs between the models that share them (one description, one rule each)
RelativeErrorTol = Annotated[
    NonNegativeFloat, Field(description="stop when the error's relative decrease in one iteration is below this [1]")
]
AbsoluteErrorTol = Annotated[
    NonNegativeFloat, Field(description="stop when the error's decrease in one iteration is below this [½ χ²]")
]
RelinearizeSkip = Annotated[
    PositiveInt, Field(description="iSAM2 checks which variables to relinearise every this many updates")
]
StepTol = Annotated[
    PositiveFloat,
    Field(
        description="an optimiser that stopped short of its tolerances has converged when the Gauss-Newton step from its "
        "answer is below this in its Mahalanobis norm: every variable within this many of its σ (graph.converged) [σ]"
    ),
]
ComputeCovariances = Annotated[
    bool, Field(description="compute the marginal covariances: world-frame pose_cov and landmark_cov")
]


class OptimizerParams(Params):
    """Batch nonlinear least squares (:func:`optimize`)."""

    optimizer: Literal["lm", "gauss_newton", "dogleg"] = Field(
        "lm", description="Levenberg-Marquardt, Gauss-Newton or Powell's Dogleg"
    )
    max_iterations: PositiveInt = Field(100, description="most iterations of the optimiser")
    relative_error_tol: RelativeErrorTol = 1e-10
    absolute_error_tol: AbsoluteErrorTol = 1e-10
    step_tol: StepTol = 0.1


class RelinearizationParams(Params):
    """iSAM2's relinearisation (:func:`isam2_params`)."""

    relinearize_threshold: NonNegativeFloat = Field(
        0.1,
        description="iSAM2 relinearises a variable whose linear update exceeds this in any tangent coordinate [m, rad]",
    )
    relinearize_skip: RelinearizeSkip = 10


class OptimizationError(RuntimeError):
    """An optimisation that reached no optimum: a non-finite or growing error, an optimiser that gave up, diverged
    or ran out of iterations, or GTSAM's own failure (an indeterminate linear system); the message says what
    happened and where."""


@contextmanager
def gtsam_errors(where: str):
    """Run the block; GTSAM's ``RuntimeError`` raised in it becomes :class:`OptimizationError` naming ``where`` and
    GTSAM's first sentence, with the variable it names as its symbol (``x12``, ``l3``)."""
    try:
        yield
    except OptimizationError:
        raise
    except RuntimeError as exc:
        first = str(exc).strip().split("\n\n")[0]
        message = " ".join(re.sub(r"\d+ \(Symbol: (\w+)\)", r"\1", first).split())
        raise OptimizationError(f"{where}: GTSAM: {message}") from exc


def X(k: int) -> int:
    return gtsam.symbol("x", int(k))


def L(j: int) -> int:
    return gtsam.symbol("l", int(j))


def symbols(char: str, ids) -> list[int]:
    """``gtsam.symbol(char, i)`` of every id (one numpy expression: the character in the top byte, the index below)."""
    return (np.uint64(ord(char)) << np.uint64(56) | np.asarray(ids, dtype=np.uint64)).tolist()


def information_models(information: np.ndarray, robust: np.ndarray | None = None, kernel=None) -> list:
    """The noise model of each factor from its information matrix (E, d, d), robustified by ``kernel`` where
    ``robust`` (E,) is set: one ``Gaussian.Information`` per distinct (matrix, robust) pair, shared by the factors
    that have it (GTSAM's factors hold their model by shared pointer)."""
    E = len(information)
    wrapped = np.zeros(E, dtype=bool) if robust is None or kernel is None else np.asarray(robust, dtype=bool)
    rows = np.ascontiguousarray(np.column_stack([np.asarray(information, dtype=float).reshape(E, -1), wrapped]))
    # each row's bytes as one value: np.unique of those is a 1-D sort (np.unique(axis=0) sorts lexicographically,
    # 20× slower on city10000's 20687 equal rows)
    _, first, index = np.unique(rows.view(np.dtype((np.void, rows.itemsize * rows.shape[1]))).ravel(), True, True)
    # the models made in the order the factors first use them: made in sorted order, each factor's model lies
    # elsewhere in memory and Levenberg-Marquardt's linearisation runs ~10 % slower (intel)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    d = information.shape[-1] if E else 0
    models = [information_model(rows[i, :-1].reshape(d, d), kernel if rows[i, -1] else None) for i in first[order]]
    return [models[k] for k in rank[index.ravel()].tolist()]


def observation_noise(R: np.ndarray, kernel: RobustKernelParams | None = None):
    """Noise of a ``BearingRangeFactor2D`` from the (range, bearing) covariance R."""
    return noise_model(_SWAP @ R @ _SWAP, kernel)


def observation_noises(problem: LandmarkProblem, kernel: RobustKernelParams | None = None) -> list:
    """The noise of each observation's factor (``problem.obs_cov``; one shared model when every observation has the same)."""
    C = problem.obs_cov
    if len(C) and np.all(C == C[0]):
        return [observation_noise(C[0], kernel)] * len(C)
    return [observation_noise(c, kernel) for c in C]


def range_noise(variance: float, kernel: RobustKernelParams | None = None):
    """Noise of a ``RangeFactor2D``: one range of the given variance [m²]."""
    return robustify(gtsam.noiseModel.Isotropic.Variance(1, float(variance)), kernel)


def landmark_step_factors(
    problem: LandmarkProblem,
    k: int,
    prior_cov: np.ndarray,
    between_cov: np.ndarray,
    obs_noises: list,
    rows: slice,
    rng_noise=None,
    range_rows: slice = slice(0, 0),
    graph: gtsam.NonlinearFactorGraph | None = None,
) -> gtsam.NonlinearFactorGraph:
    """Factors added with pose k: the prior (k = 0) or the between factor k−1 → k with covariance
    ``between_cov[k − 1]`` (``between_cov`` (K − 1, 3, 3): ``problem.cov``, or what the smoother made of it),
    pose k's observations (the rows of the observation arrays, each with its noise of ``obs_noises``,
    :func:`observation_noises`) and its beacon ranges; added to ``graph`` (returned), a new one if None."""
    graph = gtsam.NonlinearFactorGraph() if graph is None else graph
    if k == 0:
        graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(*problem.start), noise_model(prior_cov)))
    else:
        graph.add(
            gtsam.BetweenFactorPose2(
                X(k - 1), X(k), gtsam.Pose2(*problem.delta[k - 1]), noise_model(between_cov[k - 1])
            )
        )
    for j, r, b, noise in zip(
        problem.obs_id[rows], problem.obs_range[rows], problem.obs_bearing[rows], obs_noises[rows]
    ):
        graph.add(gtsam.BearingRangeFactor2D(X(k), L(j), gtsam.Rot2(float(b)), float(r), noise))
    for j, r in zip(problem.rng_id[range_rows], problem.rng_range[range_rows]):
        graph.add(gtsam.RangeFactor2D(X(k), L(j), float(r), rng_noise))
    return graph


@dataclass
class OptimizeResult:
    """A converged optimum: its values, the error ½ Σ ‖e‖² at the initial values and at the optimum, the iterations."""

    values: gtsam.Values
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


_OPTIMIZERS = {
    "lm": ("Levenberg-Marquardt", gtsam.LevenbergMarquardtParams, gtsam.LevenbergMarquardtOptimizer),
    "gauss_newton": ("Gauss-Newton", gtsam.GaussNewtonParams, gtsam.GaussNewtonOptimizer),
    "dogleg": ("Dogleg", gtsam.DoglegParams, gtsam.DoglegOptimizer),
}


def optimize(graph, initial, params: OptimizerParams) -> OptimizeResult:
    """Batch nonlinear least squares with Levenberg-Marquardt, Gauss-Newton or Dogleg; :class:`OptimizationError`
    unless it converged (module docstring)."""
    name, settings_cls, optimizer_cls = _OPTIMIZERS[params.optimizer]
    settings = settings_cls()
    settings.setMaxIterations(int(params.max_iterations))
    settings.setRelativeErrorTol(float(params.relative_error_tol))
    settings.setAbsoluteErrorTol(float(params.absolute_error_tol))
    steps: list[tuple[float, float]] = []  # (error before, error after) of every iteration
    settings.iterationHook = lambda iteration, before, after: steps.append((before, after))
    tic = time.perf_counter()
    opt = optimizer_cls(graph, initial, settings)
    initial_error = finite_error(graph, initial, f"{name}: at the initial values", opt.error())
    with gtsam_errors(name):
        values = opt.optimize()
    elapsed = time.perf_counter() - tic
    n = int(opt.iterations())
    final_error = finite_error(graph, values, f"{name}: after {n} iterations", opt.error())
    ran = f"{name}, {n} iterations, error {initial_error:.6g} → {final_error:.6g}"
    before, after = steps[-1] if steps else (initial_error, final_error)
    tol = max(
        float(params.absolute_error_tol), float(params.relative_error_tol) * before
    )  # GTSAM's "no change" (checkConvergence)
    outlier = "a gross outlier or a wrong noise model? see the robust kernel"
    if params.optimizer == "lm" and opt.lambda_() >= settings.getlambdaUpperBound():
        stop = f"gave up, no damping up to λ = {settings.getlambdaUpperBound():g} lowers the error ({outlier})"
    elif after - before > tol:
        stop = f"diverging, the last iteration raised the error by {after - before:.3g} (Levenberg-Marquardt damps the steps; {outlier})"
    elif n >= params.max_iterations and before - after > tol:
        stop = (
            f"not converged within max_iterations = {params.max_iterations}, the last iteration lowered the error by "
            f"{before - after:.3g} (raise max_iterations)"
        )
    elif final_error > initial_error:
        stop = "the error ended above where it started"
    else:
        return OptimizeResult(values, initial_error, final_error, n, elapsed)
    # stopped without converging: an error unless the answer is converged relative to the problem all the same
    done, remaining = converged(graph, values, f"{name}: the linearisation at its answer", params.step_tol, tol)
    if final_error > initial_error or not done:
        raise OptimizationError(f"{ran}: {stop}; its linearisation at the answer {remaining}")
    return OptimizeResult(values, initial_error, final_error, n, elapsed)


def converged(graph, values, where: str, step_tol: float, tol: float = 0.0) -> tuple[bool, str]:
    """Whether ``values`` is converged relative to the problem, and what its linearisation still promises (words).

    With J, b the whitened linearisation at ``values``, H = JᵀJ its information and δ = H⁻¹Jᵀb the Gauss-Newton step,
    the promised decrease is Δ = ½ δᵀHδ = ½ d², d the step's Mahalanobis norm (all variables together, in the
    information the optimiser already has; :func:`remaining_decrease`). For every linear function aᵀx of the
    variables — one coordinate, a relative pose, an aligned trajectory — |aᵀδ| ≤ d √(aᵀH⁻¹a) (Cauchy-Schwarz): within
    d of its own marginal σ. Converged: d ≤ ``step_tol`` (0.1 σ raises the expected squared error of a consistent
    estimate by at most 1 %) or Δ ≤ ``tol`` (the optimiser's own "no change").
    """
    decrease = remaining_decrease(graph, values, where)
    d = float(np.sqrt(2.0 * max(decrease, 0.0)))
    words = f"still promises a decrease of {decrease:.3g} (a step of {d:.3g} σ)"
    if decrease <= tol or d <= step_tol:
        return True, words
    return False, f"{words} > step_tol = {step_tol:g}"


def remaining_decrease(graph, values, where: str) -> float:
    """The decrease of the error that one Gauss-Newton step from ``values`` promises (the linearised model's ½‖b‖²
    minus its minimum): ½ d² with d the Mahalanobis distance of ``values`` from the optimum of the linearisation."""
    with gtsam_errors(where):
        linear = graph.linearize(values)
        step = linear.optimize(
            gtsam.EliminateQR
        )  # QR: Cholesky's pivot test (2⁻²⁴ of the diagonal) rejects stiff, determined systems
    return float(linear.error(gtsam.VectorValues.Zero(step)) - linear.error(step))


def finite_error(graph, values, where: str, error: float | None = None) -> float:
    """The error ½ Σ ‖e‖² of ``graph`` at ``values`` (``error`` when the caller has it: an optimiser's own, computed
    the same way); :class:`OptimizationError` naming ``where`` and the first factor whose error is not finite if the
    sum is not."""
    error = float(graph.error(values) if error is None else error)
    if np.isfinite(error):
        return error
    culprit = "each factor's error is finite, their sum is not"
    for i in range(graph.size()):
        factor = graph.at(i)
        if factor is not None and not np.isfinite(factor.error(values)):
            culprit = f"first at factor {i}, {type(factor).__name__} on {', '.join(gtsam.DefaultKeyFormatter(k) for k in factor.keys())}"
            break
    raise OptimizationError(f"{where}: the error is {error} ({culprit})")


def poses_of(values, keys) -> np.ndarray:
    """Poses (K, 3) of the given pose keys: read at once (``gtsam.utilities.extractPose2``: every Pose2 of ``values``
    in key order) when the keys are exactly the poses of ``values`` — all its keys when it holds only poses (a graph
    keyed by node ids: :func:`~.pose_graph.read_pose_graph`), else its ``x`` keys when those are all its poses —
    else one by one."""
    wanted = np.asarray(keys, dtype=np.uint64)
    held = np.asarray(values.keys(), dtype=np.uint64)
    every = gtsam.utilities.extractPose2(values)
    if len(every) != len(held):  # other variables beside the poses: the poses are the x keys
        held = held[held >> np.uint64(56) == ord("x")]
    if len(every) == len(held) and np.array_equal(np.sort(wanted), held):
        out = np.empty((len(keys), 3))
        out[np.argsort(wanted, kind="stable")] = every
        return out
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
