"""The pose-graph back end of laser graph SLAM, on GTSAM.

Variables: node poses X_i (Pose2, world frame). Factors:

    prior         X_0 = G_0 (tight: the first node defines the frame)
    sequential    X_{i−1}⁻¹ X_i = z_i,  z_i = L_{i−1}⁻¹ ⊕ L_i  (the front end's relative motion), Σ_i
    loop closure  X_a⁻¹ X_n = z,  z = L_a⁻¹ ⊕ M  (node n matched against the submap anchored at node a), Σ,
                  wrapped in the robust kernel (:mod:`slamarena.robust`): one false loop cannot bend the map

Incremental: new nodes and their sequential factors are buffered and handed to iSAM2 in batches; loop
closures are applied (and, when the verification withdraws one, removed: :meth:`Backend.set_loops`) at once (with
``extra_updates`` more iSAM2 iterations to relinearise), and only then are all global estimates read back.
:meth:`Backend.relative_cov` is the covariance of the relative pose X_c⁻¹ X_n of two nodes, from which the loop search
takes its windows: with J (6, 6) the joint marginal of X_c and X_m (GTSAM's ``Marginals``, each block in its node's
frame: right perturbations X Exp(ε)), X_c⁻¹ X_m = T_cm Exp(−Ad_{T_mc} ε_c + ε_m), so

    C_cm = A J Aᵀ,  A = [−Ad_{T_mc}  I₃]   (3, 6)

in m's frame. The factorisation is computed when a search needs it after the loops changed, with m the newest node
then; a node n added since is reached along the sequential factors added since (no loop joins them, so they are
independent of J): P_cn = Ad_{T_mn⁻¹} C_cm Ad_{T_mn⁻¹}ᵀ + Cov(T_mn), the chain's (:mod:`.consistency`).
:meth:`Backend.finish` runs one batch
Levenberg-Marquardt over the whole graph from iSAM2's estimate — or, with ``gnc``, GTSAM's graduated non-convexity
(Yang et al., RA-L 2020: truncated least squares on the loop factors, every other factor a known inlier), whose final
weights say which loops it kept —; a non-finite or increasing error is an :class:`OptimizationError`.
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.geometry import between, inverse
from slamarena.datasets.posegraph import PoseGraph
from slamarena.errors import UserError
from slamarena.robust import RobustKernelParams, noise_model

from .consistency import adjoint

__all__ = ["Backend", "OptimizationError", "batch_optimise"]


class OptimizationError(UserError, RuntimeError):
    """The back end's optimisation failed (non-finite or increasing error); its result is not used."""


def batch_optimise(graph, initial, max_iterations: int, what: str) -> tuple[object, dict]:
    """Levenberg-Marquardt on a GTSAM ``graph`` from ``initial``: the result (Values) and a report; a non-finite or
    increasing error is an :class:`OptimizationError` naming ``what``."""
    import gtsam

    params = gtsam.LevenbergMarquardtParams()
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
        self.edges: list[tuple[int, int, np.ndarray, np.ndarray]] = []  # sequential factors: i, j, z, Σ
        self.loops: dict[object, int] = {}  # loop key → its iSAM2 factor index
        self.loop_edges: dict[object, tuple[int, int, np.ndarray, np.ndarray]] = {}  # loop key → a, n, z, Σ
        self.n = 0
        self._kept = 0
        self._marginals = None  # (gtsam.Marginals, the newest node then, the estimate then (N, 3))

    def add_node(self, i: int, guess: np.ndarray, z: np.ndarray | None = None, cov: np.ndarray | None = None) -> None:
        """Node i with its world-frame guess; a sequential factor from node i − 1 (z, Σ) unless it is the first."""
        g = self._g
        self._values.insert(i, g.Pose2(*guess))
        if z is None:
            self._graph.add(g.PriorFactorPose2(i, g.Pose2(*guess), g.noiseModel.Isotropic.Sigma(3, self.prior_sigma)))
        else:
            self._graph.add(g.BetweenFactorPose2(i - 1, i, g.Pose2(*z), noise_model(cov)))
            self.edges.append((i - 1, i, np.asarray(z, dtype=float), np.asarray(cov, dtype=float)))
        self.n = max(self.n, i + 1)
        self.pending += 1
        if self.pending >= self.batch:
            self.flush()

    def set_loops(self, add: dict, remove: list) -> np.ndarray:
        """Loop factors: ``add`` {key: (a, n, z (3,), Σ (3, 3))} joins the graph, the loops of the keys ``remove``
        leave it; returns every node's updated world pose (N, 3)."""
        g = self._g
        self.flush()
        graph = g.NonlinearFactorGraph()
        for a, n, z, cov in add.values():
            graph.add(g.BetweenFactorPose2(a, n, g.Pose2(*z), noise_model(cov, self.kernel)))
        try:
            result = self.isam.update(graph, g.Values(), [self.loops.pop(key) for key in remove])
        except RuntimeError as exc:
            raise OptimizationError(f"iSAM2 update with {len(add)} new loop factors failed: {exc}") from None
        self.loops.update(zip(add, result.getNewFactorsIndices()))
        self.loop_edges.update(add)
        self._marginals = None
        for key in remove:
            del self.loop_edges[key]
        for _ in range(self.extra_updates):
            self.isam.update()
        return self.estimate()

    def add_loop(self, a: int, n: int, z: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """A loop-closure factor between nodes a and n (kept for good); returns every node's updated world pose (N, 3)."""
        self._kept += 1
        return self.set_loops({("kept", self._kept): (a, n, z, cov)}, [])

    def relative_cov(self, c: int, n: int, chain, covariance: bool = True) -> np.ndarray | None:
        """Covariance (3, 3) of X_c⁻¹ X_n in n's frame (module docstring), c < n; ``chain``: the sequential factors'
        :class:`~.consistency.OdometryChain`. ``covariance`` False (fixed windows, which need none): None, and only
        iSAM2's buffered factors are handed over where the marginal would be refreshed, so that iSAM2's updates, and
        with them every estimate, are those of a run that computes it."""
        g = self._g
        stale = self._marginals is None or c >= self._marginals[1]
        if not covariance:
            if stale:
                self.flush()
                self._marginals = (None, self.n - 1, None)
            return None
        if stale or self._marginals[0] is None:
            graph, values = self.graph()
            full = g.NonlinearFactorGraph()
            for k in range(graph.size()):
                if graph.at(k) is not None:
                    full.add(graph.at(k))
            self._marginals = (g.Marginals(full, values), self.n - 1, g.utilities.extractPose2(values))
        marginals, last, G = self._marginals
        m = min(n, last)
        J = marginals.jointMarginalCovariance(g.KeyVector([c, m])).fullMatrix()
        A = np.hstack([-adjoint(between(G[m], G[c])), np.eye(3)])
        C = A @ J @ A.T
        if m == n:
            return C
        T, C_mn = chain.relative(m, n)
        Ad = adjoint(inverse(T))
        return Ad @ C @ Ad.T + C_mn

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

    def finish(self, max_iterations: int = 100, gnc: bool = False) -> tuple[np.ndarray, dict]:
        """Batch Levenberg-Marquardt (or, with ``gnc``, GNC with truncated least squares on the loop factors) over the
        whole graph from iSAM2's estimate: poses (N, 3) and a report (with ``gnc``, ``loop_weights``: the final GNC
        weight of each loop, in the order of ``self.loops``)."""
        g = self._g
        graph, initial = self.graph()
        if gnc:
            return self._gnc(graph, initial, max_iterations)
        full = g.NonlinearFactorGraph()
        for k in range(graph.size()):
            if graph.at(k) is not None:
                full.add(graph.at(k))
        result, report = batch_optimise(full, initial, max_iterations, "the final batch optimisation")
        return g.utilities.extractPose2(result), report

    def _gnc(self, graph, initial, max_iterations: int) -> tuple[np.ndarray, dict]:
        g = self._g
        full, loop_at, inliers = g.NonlinearFactorGraph(), {}, []
        loop_index = {index: key for key, index in self.loops.items()}
        for k in range(graph.size()):
            factor = graph.at(k)
            if factor is None:
                continue
            if k in loop_index:  # GNC applies its own (truncated quadratic) weights to a plain Gaussian factor
                loop = self.loop_edges[loop_index[k]]
                factor = g.BetweenFactorPose2(loop[0], loop[1], g.Pose2(*loop[2]), noise_model(loop[3]))
                loop_at[loop_index[k]] = full.size()
            else:
                inliers.append(full.size())
            full.add(factor)
        params = g.GncLMParams()
        params.setKnownInliers(inliers)
        optimizer = g.GncLMOptimizer(full, initial, params)
        before = full.error(initial)
        result = optimizer.optimize()
        weights = np.asarray(optimizer.getWeights())
        if not np.all(np.isfinite(g.utilities.extractPose2(result))):
            raise OptimizationError("the final GNC optimisation returned non-finite poses")
        return g.utilities.extractPose2(result), {
            "initial_error": float(before),
            "final_error": float(full.error(result)),
            "loop_weights": {key: float(weights[i]) for key, i in loop_at.items()},
        }

    def pose_graph(self, name: str, poses: np.ndarray) -> PoseGraph:
        """The graph as the data model's :class:`PoseGraph` (for the g2o writer), with ``poses`` as its vertices: the
        sequential factors, then the loops in ``loop_edges`` (the caller drops those GNC rejected)."""
        edges = self.edges + list(self.loop_edges.values())
        i, j, z, cov = zip(*edges) if edges else ((), (), (), ())
        info = np.linalg.inv(np.asarray(cov).reshape(-1, 3, 3)) if edges else np.zeros((0, 3, 3))
        return PoseGraph(
            name=name,
            node_ids=np.arange(self.n),
            edge_i=np.asarray(i, dtype=np.int64),
            edge_j=np.asarray(j, dtype=np.int64),
            edge_z=np.asarray(z).reshape(-1, 3),
            edge_information=info,
            poses=poses,
            meta={"loop_edges": len(self.loop_edges), "robust_kernel": self.kernel.robust},
        )
