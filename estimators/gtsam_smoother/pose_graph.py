"""Pose-graph optimisation of a :class:`~slamarena.datasets.posegraph.PoseGraph` (g2o, TORO, iSAM files) with GTSAM.

Graph (2D): nodes x_i ∈ SE(2) keyed by their file ids, one ``BetweenFactorPose2`` per edge with
``Gaussian.Information(Ω)`` (one model per distinct Ω, shared by its edges: :func:`~.graph.information_models`) —
the file's information matrix in (x, y, θ) order, which is the order of GTSAM's Pose2 tangent (vx, vy, ω) and,
like g2o's, a right (body-frame) perturbation of the measured relative pose — and a prior that anchors the first node at its initial pose
(σ = ``anchor_sigma``). Landmark edges, when the graph has them: ``"xy"`` (a point in the robot
frame, iSAM's LANDMARK lines) as the factor ``e = x_i⁻¹ · l_j − z`` (``Pose2.transformTo`` with
its Jacobians, in a ``CustomFactor``); ``"bearing_range"`` with z = (bearing, range) and the
information in that order as ``BearingRangeFactor2D``. Robust kernels (``robust``) apply to the
loop closures (the edges that are not odometry i → i+1).

Initial values: ``initial="file"`` uses the file's vertices when it has them, else the odometry
chain (:meth:`PoseGraph.initial_poses`); ``initial="chain"`` always composes the chain. Landmarks
start from their first observation.

Who builds the factor graph (:func:`pose_graph_factors`): GTSAM's own C++ reader, ``gtsam.readG2o``, on the g2o file
the graph was read from when the graph still holds exactly that file's content (:func:`~slamarena.datasets.formats.g2o.source_file`:
the project's reader has validated it — information positive definite, ids, fields — and nothing was edited since)
and the result is :func:`build_pose_graph`'s problem: a 2D graph without landmark records, no robust kernel, initial
values the file's vertices or (a file without them) the odometry chain, and GTSAM's graph checked to have the same
factor count, node ids and initial poses (:func:`read_pose_graph`; its keys are the node ids). Otherwise one Python
call per factor and per variable builds it from the arrays (:func:`build_pose_graph`; keys ``x_i``, ``l_j``). Both
give one ``BetweenFactorPose2`` per edge with ``Gaussian.Information(Ω)`` (GTSAM's reader makes the same model) and
the same anchor; on the staged graphs both reach the same optimum bit for bit where the initial values are the
file's (intel, city10000); without vertices (manhattan) GTSAM's reader composes the chain in its own arithmetic (within
1e-11 of :meth:`PoseGraph.chain_initialisation`), so the optimum agrees to round-off.

Parameters: :class:`PoseGraphOptimizerParams` — the optimiser's (:class:`~.graph.OptimizerParams`,
tolerances 1e-8 by default), the robust kernel (:class:`~.graph.RobustKernelParams`), the initial
values, the anchor and whether to compute marginals.

``Estimate``: ``t`` = node ids (as float; a pose graph has no time), optimised poses, landmarks;
``pose_cov`` (world frame, from ``Marginals``) only with ``covariances=True``; diagnostics
``initial_error``, ``final_error`` (½ Σ‖e‖²_Ω), ``iterations``, ``time_optimize``; ``meta["params"]``
the canonical parameters and ``meta["initial"]`` the initialisation used. An optimisation that does not
converge (including one that runs out of ``max_iterations``) is :class:`~.graph.OptimizationError`
(:func:`~.graph.optimize`). A ``Sequence`` given to
:meth:`PoseGraphOptimizer.run` is solved by :class:`~.batch.BatchSmoother` with the same optimiser,
robust-kernel and covariance settings (its motion and observations are a pose graph with landmarks;
``meta["params"]`` is then the batch smoother's).
"""

from __future__ import annotations

import tempfile
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Literal

import gtsam
import numpy as np
from pydantic import PositiveFloat

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.formats import g2o
from slamarena.datasets.formats._text import read_bytes
from slamarena.datasets.geometry import transform_points, wrap_angle
from slamarena.datasets.posegraph import PoseGraph
from slamarena.datasets.sequence import Sequence
from slamarena.estimators.models import inverse_observe
from slamarena.params import Field

from .batch import BatchSmoother
from .graph import (
    AbsoluteErrorTol,
    ComputeCovariances,
    L,
    OptimizerParams,
    RelativeErrorTol,
    RobustKernelParams,
    X,
    gtsam_errors,
    information_model,
    information_models,
    noise_model,
    optimize,
    point_covariances,
    points_of,
    poses_of,
    symbols,
    world_pose_covariances,
)

__all__ = [
    "PoseGraphOptimizer",
    "PoseGraphOptimizerParams",
    "build_pose_graph",
    "read_pose_graph",
    "pose_graph_factors",
]


class PoseGraphOptimizerParams(OptimizerParams, RobustKernelParams):
    """Parameters of :class:`PoseGraphOptimizer`: the optimiser's, the robust kernel on the loop closures, the
    initial values, the anchor and the marginals."""

    relative_error_tol: RelativeErrorTol = 1e-8
    absolute_error_tol: AbsoluteErrorTol = 1e-8
    initial: Literal["file", "chain"] = Field(
        "file",
        description="initial poses: the file's vertices when it has them (else the odometry chain), or always the odometry chain",
    )
    anchor_sigma: PositiveFloat = Field(
        1e-6, description="σ of the prior that holds the first node at its initial pose [m, m, rad]"
    )
    covariances: ComputeCovariances = False


def _point_in_frame_factor(pose_key: int, point_key: int, z: np.ndarray, model) -> gtsam.CustomFactor:
    """e = x⁻¹ · l − z: a landmark seen at the robot-frame point z (2,)."""
    z = np.asarray(z, dtype=float)

    def error(this: gtsam.CustomFactor, values: gtsam.Values, H):
        pose = values.atPose2(this.keys()[0])
        point = values.atPoint2(this.keys()[1])
        if H is None:
            return pose.transformTo(point) - z
        Hx, Hl = np.zeros((2, 3), order="F"), np.zeros((2, 2), order="F")
        e = pose.transformTo(point, Hx, Hl) - z
        H[0], H[1] = Hx, Hl
        return e

    return gtsam.CustomFactor(model, [pose_key, point_key], error)


def build_pose_graph(
    graph: PoseGraph, params: PoseGraphOptimizerParams = PoseGraphOptimizerParams()
) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
    """The GTSAM factor graph and initial values of a 2D :class:`PoseGraph`."""
    if graph.dim != 2:
        raise NotImplementedError(f"{graph.name}: only 2D pose graphs are optimised (got dim={graph.dim})")
    poses = graph.initial_poses() if params.initial == "file" else graph.chain_initialisation()
    factors = gtsam.NonlinearFactorGraph()
    models = information_models(graph.edge_information, ~graph.odometry_mask(), params)
    for i, j, (dx, dy, dth), model in zip(
        symbols("x", graph.edge_i), symbols("x", graph.edge_j), graph.edge_z.tolist(), models
    ):
        factors.add(gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(dx, dy, dth), model))
    # the anchor after the edges, where GTSAM's reader leaves it (read_pose_graph): the factor order sets the order of
    # the sums in the linear systems, so both give the same optimum bit for bit
    factors.add(
        gtsam.PriorFactorPose2(
            X(graph.node_ids[0]), gtsam.Pose2(*poses[0]), noise_model(np.eye(3) * params.anchor_sigma**2)
        )
    )
    values = gtsam.Values()
    for key, (x, y, th) in zip(symbols("x", graph.node_ids), np.asarray(poses, dtype=float).tolist()):
        values.insert(key, gtsam.Pose2(x, y, th))
    if graph.landmark_pose is not None:
        rows = graph.index_of(graph.landmark_pose)
        ids, first = np.unique(graph.landmark_id, return_index=True)
        if graph.landmark_kind == "xy":
            for i, j, z, info in zip(
                graph.landmark_pose, graph.landmark_id, graph.landmark_z, graph.landmark_information
            ):
                factors.add(_point_in_frame_factor(X(i), L(j), z, information_model(info)))
            seen = transform_points(poses[rows[first]], graph.landmark_z[first])
        else:
            for i, j, z, info in zip(
                graph.landmark_pose, graph.landmark_id, graph.landmark_z, graph.landmark_information
            ):
                factors.add(
                    gtsam.BearingRangeFactor2D(
                        X(i), L(j), gtsam.Rot2(float(z[0])), float(z[1]), information_model(info)
                    )
                )
            seen = inverse_observe(poses[rows[first]], graph.landmark_z[first][:, ::-1])
        for j, m in zip(ids, seen):
            values.insert(L(j), gtsam.Point2(*m))
    return factors, values


#: initial poses GTSAM's reader gives are those of the arrays when they agree to this [m, rad] (the vertices: exactly
#: up to atan2's last bit; a chain: to its composition's round-off, ≈ 1e-11 over manhattan's 3500 steps)
_SAME_INITIAL = 1e-9


@contextmanager
def plain_text(path: Path):
    """``path`` as a plain-text file (GTSAM's reader reads no gzip: a ``.gz`` is written to a temporary file as the
    project's readers read it, :func:`~slamarena.datasets.formats._text.read_bytes`)."""
    if path.suffix != ".gz":
        yield path
        return
    with tempfile.TemporaryDirectory() as tmp:
        plain = Path(tmp) / path.stem
        plain.write_bytes(read_bytes(path))
        yield plain


def read_pose_graph(
    graph: PoseGraph, params: PoseGraphOptimizerParams = PoseGraphOptimizerParams()
) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values] | None:
    """:func:`build_pose_graph`'s factor graph and initial values made by GTSAM's C++ reader (``gtsam.readG2o``) from
    the g2o file the graph was read from, keyed by the node ids (module docstring); None when that is not the same
    problem: not a 2D graph holding exactly its file's validated content, landmark records, a robust kernel, initial
    values other than the file's, or GTSAM's reading differs in factor count, node ids or initial poses (or fails)."""
    if graph.dim != 2 or graph.landmark_pose is not None or "landmark_ids" in graph.meta or params.robust != "none":
        return None
    if params.initial == "chain" and graph.poses is not None:
        return None
    path = g2o.source_file(graph)
    if path is None:
        return None
    try:
        with plain_text(path) as plain:
            factors, values = gtsam.readG2o(str(plain), False)
    except RuntimeError:
        return None
    ids = graph.node_ids
    keys = np.asarray(values.keys(), dtype=np.int64)
    if factors.size() != graph.n_edges or not np.array_equal(keys, np.sort(ids)):
        return None
    order = np.argsort(ids, kind="stable")
    expected = graph.initial_poses()[order]
    got = gtsam.utilities.extractPose2(values)
    diff = np.abs(np.column_stack([got[:, :2] - expected[:, :2], wrap_angle(got[:, 2] - expected[:, 2])]))
    if not np.all(diff <= _SAME_INITIAL * np.maximum(1.0, np.abs(expected))):
        return None
    first = int(ids[0])
    factors.add(gtsam.PriorFactorPose2(first, values.atPose2(first), noise_model(np.eye(3) * params.anchor_sigma**2)))
    return factors, values


def pose_graph_factors(
    graph: PoseGraph, params: PoseGraphOptimizerParams = PoseGraphOptimizerParams()
) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values, list[int], str]:
    """The factor graph, initial values and pose keys (in ``graph.node_ids`` order) of a 2D pose graph, and who built
    them: ``"gtsam.readG2o"`` (:func:`read_pose_graph`) where it gives the same problem, else ``"arrays"``
    (:func:`build_pose_graph`)."""
    read = read_pose_graph(graph, params)
    if read is not None:
        return *read, graph.node_ids.tolist(), "gtsam.readG2o"
    return *build_pose_graph(graph, params), symbols("x", graph.node_ids), "arrays"


class PoseGraphOptimizer:
    """Nonlinear least squares on a 2D pose graph (:class:`PoseGraphOptimizerParams`)."""

    Params = PoseGraphOptimizerParams

    #: the parameters a Sequence's batch smoother takes from these
    _BATCH_FIELDS = {*OptimizerParams.model_fields, *RobustKernelParams.model_fields, "covariances"}

    def __init__(self, params: PoseGraphOptimizerParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def run(self, data: PoseGraph | Sequence) -> Estimate:
        if isinstance(data, Sequence):
            smoother = BatchSmoother(self.params.model_dump(include=self._BATCH_FIELDS))
            estimate = smoother.run(data)
            estimate.method = "gtsam_pose_graph"
            return estimate
        if not isinstance(data, PoseGraph):
            raise TypeError(f"PoseGraphOptimizer.run takes a PoseGraph or a Sequence, not {type(data).__name__}")
        tic = time.perf_counter()
        graph, initial, pose_keys, built_by = pose_graph_factors(data, self.params)
        time_build = time.perf_counter() - tic
        result = optimize(graph, initial, self.params)
        poses = poses_of(result.values, pose_keys)
        ids = landmarks = pose_cov = landmark_cov = None
        if data.landmark_id is not None:
            ids = np.unique(data.landmark_id)
            landmarks = points_of(result.values, [L(j) for j in ids])
        if self.params.covariances:
            with gtsam_errors("marginal covariances"):
                marginals = gtsam.Marginals(graph, result.values)
                pose_cov = world_pose_covariances(marginals.marginalCovariance, pose_keys, poses)
                if ids is not None:
                    landmark_cov = point_covariances(marginals.marginalCovariance, [L(j) for j in ids])
        diagnostics = {
            "initial_error": result.initial_error,
            "final_error": result.final_error,
            "iterations": result.iterations,
            "time_optimize": result.time_s,
            "time_build": time_build,
        }
        return Estimate(
            method="gtsam_pose_graph",
            t=data.node_ids.astype(float),
            poses=poses,
            pose_cov=pose_cov,
            landmark_ids=ids,
            landmarks=landmarks,
            landmark_cov=landmark_cov,
            diagnostics=diagnostics,
            meta={
                "params": self.params.canonical(),
                "graph": data.name,
                "nodes": data.n_nodes,
                "edges": data.n_edges,
                "initial": "file" if (self.params.initial == "file" and data.poses is not None) else "chain",
                "built_by": built_by,
            },
        )
