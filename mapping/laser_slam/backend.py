"""The pose-graph back end of laser graph SLAM, on GTSAM.

Variables: node poses X_i (Pose2, world frame). Factors:

    prior         X_0 = G_0 (tight: the first node defines the frame)
    sequential    X_{i−1}⁻¹ X_i = z_i,  z_i = L_{i−1}⁻¹ ⊕ L_i  (the front end's relative motion), Σ_i
    loop closure  X_a⁻¹ X_n = z,  z = L_a⁻¹ ⊕ M  (node n matched against the submap anchored at node a), Σ,
                  wrapped in the robust kernel (:mod:`slamarena.robust`): one false loop cannot bend the map

Incremental: new nodes and their sequential factors are buffered and handed to iSAM2 in batches; a loop
closure is applied at once (with ``extra_updates`` more iSAM2 iterations to relinearise), and only then are
all global estimates read back. :meth:`Backend.finish` runs one batch Levenberg-Marquardt over the whole
graph from iSAM2's estimate; a non-finite or increasing error is an :class:`OptimizationError`.
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.posegraph import PoseGraph
from slamarena.errors import UserError
from slamarena.robust import RobustKernelParams, noise_model

__all__ = ["Backend", "OptimizationError", "batch_optimise"]


class OptimizationError(UserError, RuntimeError):
    """The back end's optimisation failed (non-finite or increasing error); its result is not used."""


def batch_optimise(graph, initial, max_iterations: int, what: str) -> tuple[object, dict]:
    """Levenberg-Marquardt on a GTSAM ``graph`` from ``initial``: the result (Values) and a report; a non-finite or
    increasing error is an :class:`OptimizationError` naming ``what``."""
    import gtsam

    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    before = graph.error(initial)
    result = optimizer.optimize()
    after = graph.error(result)
    if not (np.isfinite(before) and np.isfinite(after)) or after > before * (1 + 1e-9) + 1e-9:
        raise OptimizationError(f"{what} did not converge: error {before:.6g} → {after:.6g}")
    return result, {
        "initial_error": float(before),
        "final_error": float(after),
        "iterations": int(optimizer.iterations()),
    }


class Backend:
    """Pose graph of the nodes (module docstring)."""

    def __init__(self, kernel: RobustKernelParams, batch: int = 10, extra_updates: int = 2, prior_sigma: float = 1e-6):
        import gtsam

        self._g = gtsam
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(0.01)
        params.relinearizeSkip = 1
        self.isam = gtsam.ISAM2(params)
        self.kernel = kernel
        self.batch = batch
        self.extra_updates = extra_updates
        self.prior_sigma = prior_sigma
        self._graph = gtsam.NonlinearFactorGraph()
        self._values = gtsam.Values()
        self.pending = 0
        self.edges: list[tuple[int, int, np.ndarray, np.ndarray, bool]] = []  # i, j, z, Σ, loop?
        self.n = 0

    def add_node(self, i: int, guess: np.ndarray, z: np.ndarray | None = None, cov: np.ndarray | None = None) -> None:
        """Node i with its world-frame guess; a sequential factor from node i − 1 (z, Σ) unless it is the first."""
        g = self._g
        self._values.insert(i, g.Pose2(*guess))
        if z is None:
            self._graph.add(g.PriorFactorPose2(i, g.Pose2(*guess), g.noiseModel.Isotropic.Sigma(3, self.prior_sigma)))
        else:
            self._graph.add(g.BetweenFactorPose2(i - 1, i, g.Pose2(*z), noise_model(cov)))
            self.edges.append((i - 1, i, np.asarray(z, dtype=float), np.asarray(cov, dtype=float), False))
        self.n = max(self.n, i + 1)
        self.pending += 1
        if self.pending >= self.batch:
            self.flush()

    def add_loop(self, a: int, n: int, z: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """A loop-closure factor between nodes a and n; returns every node's updated world pose (N, 3)."""
        g = self._g
        self._graph.add(g.BetweenFactorPose2(a, n, g.Pose2(*z), noise_model(cov, self.kernel)))
        self.edges.append((a, n, np.asarray(z, dtype=float), np.asarray(cov, dtype=float), True))
        self.flush()
        for _ in range(self.extra_updates):
            self.isam.update()
        return self.estimate()

    def flush(self) -> None:
        """Hand the buffered factors and values to iSAM2."""
        if self._graph.size() == 0 and self._values.size() == 0:
            return
        try:
            self.isam.update(self._graph, self._values)
        except RuntimeError as exc:
            raise OptimizationError(f"iSAM2 update with {self._graph.size()} new factors failed: {exc}") from None
        self._graph = self._g.NonlinearFactorGraph()
        self._values = self._g.Values()
        self.pending = 0

    def estimate(self) -> np.ndarray:
        """iSAM2's current estimate of every node (N, 3)."""
        self.flush()
        return self._g.utilities.extractPose2(self.isam.calculateEstimate())

    def graph(self) -> tuple[object, object]:
        """The whole factor graph and iSAM2's estimate."""
        self.flush()
        return self.isam.getFactorsUnsafe(), self.isam.calculateEstimate()

    def finish(self, max_iterations: int = 100) -> tuple[np.ndarray, dict]:
        """Batch Levenberg-Marquardt over the whole graph from iSAM2's estimate: poses (N, 3) and a report."""
        g = self._g
        graph, initial = self.graph()
        full = g.NonlinearFactorGraph()
        for k in range(graph.size()):
            if graph.at(k) is not None:
                full.add(graph.at(k))
        result, report = batch_optimise(full, initial, max_iterations, "the final batch optimisation")
        return g.utilities.extractPose2(result), report

    def pose_graph(self, name: str, poses: np.ndarray) -> PoseGraph:
        """The graph as the data model's :class:`PoseGraph` (for the g2o writer), with ``poses`` as its vertices."""
        i, j, z, cov, loop = zip(*self.edges) if self.edges else ((), (), (), (), ())
        info = np.linalg.inv(np.asarray(cov).reshape(-1, 3, 3)) if self.edges else np.zeros((0, 3, 3))
        return PoseGraph(
            name=name,
            node_ids=np.arange(self.n),
            edge_i=np.asarray(i, dtype=np.int64),
            edge_j=np.asarray(j, dtype=np.int64),
            edge_z=np.asarray(z).reshape(-1, 3),
            edge_information=info,
            poses=poses,
            meta={"loop_edges": int(np.sum(loop)), "robust_kernel": self.kernel.robust},
        )
