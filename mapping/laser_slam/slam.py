"""Laser graph SLAM: the scan-to-submap front end, loop closure against finished submaps, a GTSAM pose graph.

Front end (:mod:`slamarena.mapping.frontend`). Every scan k is matched against one map of every node so far
(``tracking="global"``, as grid SLAM) or against the older of the (at most two) active submaps (``"submap"``, as
Cartographer), giving its front-end ("local") pose L_k. The global map keeps the heading along the long corridors
of FR-Clinic, where the submap front end drifts by ~10° over 300 m and no loop closes it
(research/notebook/2026-11-21-grid-slam-results.md). A scan the motion filter passes becomes node i
(scan k_i, pose L_i) and is inserted into every active submap. Submaps (as Cartographer): a new submap is
started when the newest has ``submap_scans`` insertions, and the older is finished at 2·``submap_scans``, so
consecutive submaps overlap by half and the one matched against is never nearly empty. A submap is an
occupancy-grid pyramid in the front-end frame, anchored at its first node (the graph optimises the anchor's
pose, and with it the submap's).

Graph (:mod:`.backend`). Nodes X_i (world poses G_i). Sequential factors z_i = L_{i−1}⁻¹ ⊕ L_i with
covariance R_iᵀ C_i R_i + diag(σ_t², σ_t², σ_θ²) (C_i: the matcher's covariance of node i's match in the
front-end frame, R_i the rotation of node i's front-end pose L_i — the frame of z's end, in which GTSAM's
BetweenFactorPose2 measures its error, Log(z⁻¹ X_{i−1}⁻¹ X_i); the floor σ because a Gauss-Newton Laplace
covariance ignores the map's own error). With ``odometry_noise`` set, R_iᵀ C_i R_i is replaced by the odometry's
covariance accumulated over the interval fused with the node scan's match information, Q (I₃ + R_iᵀ I_i R_i Q)⁻¹
(:mod:`.interval`), and the refinement's pairwise factors keep the front end's relative pose along a direction the
scan does not constrain (the front end's ``degeneracy_threshold``; :meth:`LaserSLAM._pairwise_kept`).
Loop closures (:mod:`.loop_closure`) every ``loop.search_every`` nodes,
searched within windows from the graph's marginal covariance, required to be unique there, robustified, and verified
(``loop.verify``): with ``"pcm"`` every unique match joins the pairwise consistency test against the others and the
front end's chain (:mod:`.consistency`) and the graph holds exactly the current largest consistent set (loops leave
it when a larger set excludes them); with ``"gnc"`` (the default) every unique match joins the graph and the final solve is GTSAM's
GNC, whose weights reject loops; ``"none"`` leaves them to the robust kernel. A robustness study
(``loop.false_loops`` > 0) injects deliberately false loop closures: at the first search after scan ⌊K·j/(F+1)⌋
(j = 1 … F) node n is claimed to sit at the position of the node c of a finished
submap whose estimated distance to it is nearest to ``loop.false_loop_distance`` (a wrong place that looks alike, e.g.
the next door along a corridor), z = (0, 0, θ_n − θ_c), with the tightest covariance a real loop can get
(the floors ``loop.sigma_*``²), and meet the verification as a matched loop would; they are listed in
``diagnostics["false_loop_node"]`` / ``["false_loop_anchor"]``.
iSAM2 keeps the estimate current as nodes and loops arrive; a new node's world pose is
G_i = G_{i−1} ⊕ z_i until the next loop refreshes all. At the end one batch Levenberg-Marquardt (or GNC).

Local refinement (:mod:`.refine`; ``refine.neighbours`` = m > 0): as each scan k is matched, its end points within
``refine.max_range`` are registered onto those of the m scans before it by point-to-line ICP
(:mod:`~slamarena.mapping.scan_matching.point_to_line`) from the front end's relative pose; a registration pairing
at least ``refine.min_paired`` of the points gives a pairwise factor. After the node graph's batch solve, every
scan becomes a variable: the nodes held at their optimised poses, every other scan tied to its node by the front
end's relative pose, and the pairwise factors place the scans between the nodes.

Output: one pose per scan at the scan stamps, G_k = G_{i(k)} ⊕ (L_{i(k)}⁻¹ ⊕ L_k) with i(k) the last node at or
before scan k (relations refer to any scan; the refined poses when m > 0), and the front end's L_k (``diagnostics["front_end_poses"]``, the
trajectory before loop closure); the map re-rendered from the nodes' optimised poses
(``self.map``); the pose graph (``self.pose_graph``, written as g2o by the CLI); the loop candidates with
their scores (``diagnostics["loop_*"]``) and the CPU time spent in the front end, the pairwise ICP, the loop search
and the optimisation (``meta["seconds"]``; CPU and not wall time, so that a loaded machine does not inflate it);
``step_time`` the CPU time of each scan as measured (a loop search and the graph update it triggers are charged to
its scan, the final batch solve and refinement to the last scan), summing to ``meta["seconds"]``'s total.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import PositiveFloat, PositiveInt
from scipy.stats import chi2

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, compose, wrap_angle
from slamarena.datasets.sequence import Scans, Sequence
from slamarena.params import Field, Params
from slamarena.robust import RobustKernelParams

from ..frontend import FrontEnd, FrontEndParams
from ..map_pyramid import MapPyramid, PackedPyramid, PyramidParams
from ..occupancy_grid import OccupancyGrid
from ..scan_matching.gauss_newton import scan_information
from ..scan_matching.point_to_line import PointToLineICPMatcher
from .backend import Backend
from .consistency import ConsistentSet, OdometryChain
from .interval import IntervalCovariance, OdometryNoiseParams, fuse
from .loop_closure import LoopCloser, LoopClosureParams
from .refine import RefineParams, refine_scans

__all__ = ["LaserSLAM", "LaserSLAMParams", "Submap"]


class LaserSLAMParams(Params):
    """Parameters of :class:`LaserSLAM`: the front end (:class:`~slamarena.mapping.frontend.FrontEndParams`) and the
    map pyramid of the tracking map and of every submap (:class:`~slamarena.mapping.map_pyramid.PyramidParams`), the
    submaps, the graph's noise and robust kernel, the loop-closure search (:class:`.loop_closure.LoopClosureParams`)
    and the local refinement (:class:`.refine.RefineParams`)."""

    frontend: FrontEndParams = Field(FrontEndParams(), description="the scan-to-map front end")
    pyramid: PyramidParams = Field(
        PyramidParams(), description="the map pyramid (tracking map and submaps) and its cell model"
    )
    submap_scans: PositiveInt = Field(
        45, description="insertions after which the next submap starts (a submap holds 2 · submap_scans)"
    )
    tracking: Literal["submap", "global"] = Field(
        "global",
        description="what the front end matches each scan against: one map of every node (Hector), or the older "
        "active submap (Cartographer)",
    )
    odometry_noise: OdometryNoiseParams | None = Field(
        None,
        description="the odometry's noise: a front-end relative pose's covariance is then the odometry's accumulated "
        "over its interval fused with its end's match (mapping/laser_slam/interval.py; meant with the front end's "
        "degeneracy_threshold > 0); None, the default: the match's covariance alone, as with degeneracy off",
    )
    sigma_translation: PositiveFloat = Field(0.02, description="floor of a sequential factor's translation σ [m]")
    sigma_rotation: PositiveFloat = Field(0.005, description="floor of a sequential factor's rotation σ [rad]")
    robust_kernel: RobustKernelParams = Field(
        RobustKernelParams(robust="cauchy", robust_k=1.0),
        description="m-estimator of the loop factors (and of the refinement's pairwise factors)",
    )
    loop: LoopClosureParams = Field(LoopClosureParams(), description="the loop-closure search")
    refine: RefineParams = Field(RefineParams(), description="the local refinement of the scans between the nodes")


class Submap:
    """One submap: its index, its grids in the front-end frame, the nodes inserted into it (the first is its anchor).

    A finished submap is stored packed (:class:`~slamarena.mapping.map_pyramid.PackedPyramid`: its observed tiles);
    reading ``maps`` unpacks it, and :meth:`release` drops the dense copy again (the loop search keeps the last
    ``loop.cache_submaps`` it read dense)."""

    def __init__(self, index: int, maps: MapPyramid):
        self.index = index
        self._maps: MapPyramid | None = maps
        self.packed: PackedPyramid | None = None
        self.nodes: list[int] = []
        self.finished = False

    @property
    def maps(self) -> MapPyramid:
        if self._maps is None:
            self._maps = self.packed.unpack()
        return self._maps

    def finish(self) -> None:
        """Never integrated again: packed, and the dense pyramid (with its tracing scratch) dropped."""
        self.finished = True
        self.packed = PackedPyramid(self._maps)
        self._maps = None

    def release(self) -> None:
        """Drop the dense copy of a finished submap (it is unpacked again when read)."""
        if self.packed is not None:
            self._maps = None


@dataclass
class _Run:
    """The state of one :meth:`LaserSLAM.run`: the scans and the parts working on them; per scan its front-end pose
    L_k (``local`` (K, 3)), match covariance C_k (K, 3, 3), node i(k) and CPU time; per node its front-end pose L_i,
    world pose G_i (``G`` (N, 3)) and scan; the active submaps, the pairwise registrations, the false loops
    added and the CPU time per part (``seconds``)."""

    scans: Scans
    K: int
    front: FrontEnd
    loops: LoopCloser
    backend: Backend
    icp: PointToLineICPMatcher
    pose: np.ndarray  # the current front-end pose
    tracking: MapPyramid | None
    local: np.ndarray
    node_of_scan: np.ndarray  # i(k): the last node at or before scan k
    match_cov: np.ndarray  # C_k, zero where scan k was not matched
    match_info: np.ndarray  # I_k (K, 3, 3): the match's information (front-end frame), zero where not matched
    odo_cov: np.ndarray  # Q_k (K, 3, 3): the odometry's covariance since the last node (scan k's frame), NaN: none
    interval: IntervalCovariance | None
    step_time: np.ndarray  # CPU time of each scan's steps, its loop search and optimisation included
    false_at: list[int]  # scans after which a false loop is due
    pair_floor: np.ndarray
    diag: dict
    chain: OdometryChain = field(default_factory=OdometryChain)  # the sequential factors, for the windows and PCM
    consistent: ConsistentSet | None = None  # loop.verify = "pcm": the loops met so far, their largest consistent set
    vertex_key: list = field(default_factory=list)  # per vertex of ``consistent``: record index or ("false", j)
    L: list[np.ndarray] = field(default_factory=list)  # node poses, front end
    G: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # node poses, world (current estimate)
    node_scan: list[int] = field(default_factory=list)
    false_loops: list[tuple[int, int]] = field(default_factory=list)
    recent: list = field(default_factory=list)  # the last refine.neighbours scans with their prepared ICP references
    pairs: list = field(default_factory=list)  # pairwise registrations (a, k, z, Σ)
    active: list[Submap] = field(default_factory=list)
    # finished submaps the loop search read last (kept dense), oldest first
    dense: OrderedDict = field(default_factory=OrderedDict)
    seconds: dict = field(
        default_factory=lambda: {"front_end": 0.0, "loop_search": 0.0, "optimisation": 0.0, "pairwise": 0.0}
    )

    @contextmanager
    def timed(self, part: str):
        """Charge the CPU time of the block to ``seconds[part]``."""
        tic = time.process_time()
        try:
            yield
        finally:
            self.seconds[part] += time.process_time() - tic


class LaserSLAM:
    """Laser graph SLAM with loop closure (module docstring; :class:`LaserSLAMParams`)."""

    Params = LaserSLAMParams

    def __init__(self, params: LaserSLAMParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.map: OccupancyGrid | None = None
        self.pose_graph = None
        self.submaps: list[Submap] = []

    def _reach(self, scans) -> float:
        """How far a scan updates the maps [m]: the laser's range, or the no-returns' clearing range if shorter."""
        return min(scans.max_range, self.params.frontend.clear_range)

    def _new_submap(self, centre, scans) -> Submap:
        maps = MapPyramid.around(self.params.pyramid, centre, self._reach(scans))
        submap = Submap(len(self.submaps), maps)
        self.submaps.append(submap)
        return submap

    def run(self, sequence: Sequence, progress=None) -> Estimate:
        """Map ``sequence.scans``; ``progress(k, K)`` is called after each scan when given."""
        p = self.params
        run = self._start(sequence)
        for k in range(run.K):
            step_start = time.process_time()
            with run.timed("front_end"):
                beams = self._track(run, k)
            if p.refine.neighbours:
                with run.timed("pairwise"):
                    self._register_pairwise(run, k, beams)
            if len(beams.points) >= p.frontend.min_beams and run.front.due(run.pose):
                with run.timed("front_end"):
                    i = self._insert_node(run, k, beams)
                with run.timed("optimisation"):
                    self._add_to_graph(run, i, k)
                if p.loop.enabled and i % p.loop.search_every == 0:
                    with run.timed("loop_search"):
                        found = self._search_loops(run, i, k, beams)
                    with run.timed("optimisation"):
                        self._close_loops(run, i, k, found)
            run.node_of_scan[k] = len(run.L) - 1
            run.step_time[k] = time.process_time() - step_start
            if progress is not None:
                progress(k + 1, run.K)
        finish_start = time.process_time()
        run.tracking = None  # no scan is matched again: the final solve, the refinement and the map need neither the
        for submap in run.active:  # tracking map, nor dense submaps, nor the loop search's cached grids (memory at the
            submap.finish()  # end of a long log)
        for submap in self.submaps:
            submap.release()
        run.loops.release()
        with run.timed("optimisation"):
            G, report = run.backend.finish(gnc=p.loop.verify == "gnc")
        for key, weight in report.pop("loop_weights", {}).items():
            if weight < 0.5:  # GNC's verdict: out of the record's accepted loops and of the graph written
                self._set_test(run, key, "gnc")
                del run.backend.loop_edges[key]
        poses, refinement = self._scan_poses(run, G)
        run.step_time[-1] += time.process_time() - finish_start  # the final solve (and refinement) is the last scan's
        return self._estimate(sequence, run, G, poses, report, refinement)

    def _start(self, sequence: Sequence) -> _Run:
        """The run's state before the first scan: the front end, loop closer and graph, no nodes or submaps, the
        start pose and (``tracking="global"``) the empty tracking map around it."""
        scans = sequence.scans
        if scans is None or len(scans) == 0:
            raise ValueError(f"LaserSLAM needs a sequence with laser scans; {sequence.name!r} has none")
        p = self.params
        K = len(scans)
        front = FrontEnd(p.frontend, scans)
        self.submaps = []
        pose = front.start_pose(sequence.start_pose)
        chain = OdometryChain()
        return _Run(
            scans=scans,
            K=K,
            front=front,
            loops=LoopCloser(p.loop),
            backend=Backend(p.robust_kernel),
            icp=PointToLineICPMatcher(p.refine.matcher),
            pose=pose,
            tracking=MapPyramid.around(p.pyramid, pose, self._reach(scans)) if p.tracking == "global" else None,
            local=np.zeros((K, 3)),
            node_of_scan=np.full(K, -1, dtype=np.int64),
            match_cov=np.zeros((K, 3, 3)),
            match_info=np.zeros((K, 3, 3)),
            odo_cov=np.full((K, 3, 3), np.nan),
            interval=IntervalCovariance(p.odometry_noise) if p.odometry_noise is not None else None,
            step_time=np.zeros(K),
            false_at=[K * j // (p.loop.false_loops + 1) for j in range(1, p.loop.false_loops + 1)],
            pair_floor=np.diag(
                np.square([p.refine.sigma_translation, p.refine.sigma_translation, p.refine.sigma_rotation])
            ),
            chain=chain,
            consistent=ConsistentSet(chain, float(chi2.ppf(p.loop.consistency_confidence, 3)))
            if p.loop.verify == "pcm"
            else None,
            diag={
                "matched": np.zeros(K, bool),
                "score": np.full(K, np.nan),
                "usable_beams": np.zeros(K, np.int64),
                "bad_beams": np.zeros(K, np.int64),
            },
        )

    def _track(self, run: _Run, k: int):
        """Scan k's beams, matched from the odometry guess against the tracking map (or the older active submap):
        its front-end pose L_k (``run.pose``, ``run.local[k]``) and match covariance C_k (3, 3). Returns the beams."""
        front, diag = run.front, run.diag
        beams = front.beams(k)
        diag["usable_beams"][k], diag["bad_beams"][k] = beams.usable.sum(), beams.bad.sum()
        run.pose = front.guess(k, run.local, run.pose)
        if run.interval is not None:
            run.interval.step(front.motion)
            if run.interval.Q is not None:
                run.odo_cov[k] = run.interval.Q
        if run.active:
            res = front.match(run.active[0].maps if run.tracking is None else run.tracking, beams, run.pose)
            if res is not None:
                run.pose = res.pose
                diag["matched"][k], diag["score"][k] = True, res.score
                run.match_cov[k] = _finite(res.cov)
                run.match_info[k] = _information(res)
        run.local[k] = run.pose
        return beams

    def _register_pairwise(self, run: _Run, k: int, beams) -> None:
        """Scan k's end points within ``refine.max_range`` registered by ICP onto the last ``refine.neighbours``
        scans: a pairwise factor (a, k, z (3,), Σ (3, 3)) for each registration pairing enough points."""
        p = self.params
        pts = beams.points[np.hypot(*beams.points.T) < p.refine.max_range]
        if len(pts) < p.frontend.min_beams:
            return
        for a, reference in run.recent:
            guess = between(run.local[a], run.pose)
            r = run.icp.match(reference, pts, guess)
            if r.score >= p.refine.min_paired and np.all(np.isfinite(r.cov)):
                z, cov = self._pairwise_kept(pts, guess, r.pose, r.cov)
                run.pairs.append((a, k, z, _in_end_frame(cov, z[2]) + run.pair_floor))
        run.recent = run.recent[-(p.refine.neighbours - 1) :] if p.refine.neighbours > 1 else []
        run.recent.append((k, run.icp.prepare(pts)))

    def _pairwise_kept(self, pts: np.ndarray, guess: np.ndarray, z: np.ndarray, cov: np.ndarray):
        """A pairwise registration z (3,) with covariance Σ (3, 3, the start scan's frame) of the end points ``pts``
        from ``guess`` (the front end's relative pose), degeneracy-aware as the front end's match (the front end's
        ``degeneracy_threshold`` τ): where the translation information of the scan's geometry is below τ times its
        largest along u_0, z keeps the guess along u_0 and its information there is dropped (Σ's variance along u_0
        (10³ m)²): the hanging factor, the odometry's, carries that direction. Else (z, Σ) unchanged."""
        tau = getattr(self.params.frontend.matcher_model, "degeneracy_threshold", 0.0)
        if tau == 0:
            return z, cov
        lam, U = np.linalg.eigh(scan_information(pts, z)[:2, :2])
        if not lam[0] < tau * lam[1]:
            return z, cov
        u = np.array([U[0, 0], U[1, 0], 0.0])
        P = np.eye(3) - np.outer(u, u)
        kept = P @ np.linalg.pinv(cov, hermitian=True) @ P + np.outer(u, u) / _UNCONSTRAINED**2
        z = z + u * (u @ (guess - z))
        return z, np.linalg.inv(kept)

    def _insert_node(self, run: _Run, k: int, beams) -> int:
        """Scan k becomes node i (returned): a new submap when the newest is full, the scan integrated into every
        active submap (and the tracking map), the oldest submap finished at 2 · ``submap_scans`` nodes."""
        p, pose, active = self.params, run.pose, run.active
        i = len(run.L)
        if not active or len(active[-1].nodes) >= p.submap_scans:
            active.append(self._new_submap(pose, run.scans))
        first, *rest = [s.maps for s in active] + ([run.tracking] if run.tracking is not None else [])
        first.integrate(
            beams.r[beams.mapped],
            beams.a[beams.mapped],
            pose,
            run.scans.mount,
            max_range=run.front.limit,
            clear_range=p.frontend.clear_range,
            also=rest,
        )
        for submap in active:
            submap.nodes.append(i)
        if len(active[0].nodes) >= 2 * p.submap_scans:
            active.pop(0).finish()
        run.front.inserted(pose)
        if run.interval is not None:
            run.interval.reset()
        run.L.append(pose.copy())
        run.node_scan.append(k)
        return i

    def _add_to_graph(self, run: _Run, i: int, k: int) -> None:
        """Node i into the graph with its sequential factor z_i = L_{i−1}⁻¹ ⊕ L_i (covariance from C_k and the
        floors); its world pose G_i = G_{i−1} ⊕ z_i appended to ``run.G`` (N, 3)."""
        if i == 0:
            run.G = run.pose[None, :].copy()
            run.backend.add_node(0, run.pose)
            run.chain.add(run.pose, None)
            return
        L = run.L
        z = between(L[i - 1], L[i])
        cov = self._front_end_cov(L[i], run.match_cov[k], run.match_info[k], run.odo_cov[k])
        run.chain.add(L[i], cov)
        run.G = np.vstack([run.G, compose(run.G[i - 1], z)])
        run.backend.add_node(i, run.G[i], z, cov)

    def _search_loops(self, run: _Run, i: int, k: int, beams) -> list:
        """The loop closures (record index, c, z (3,), Σ (3, 3)) found for node i (scan k) against the finished
        submaps within the marginal windows."""
        found = []
        diag, Ln = run.diag, np.asarray(run.L)

        def relative(c: int, n: int, covariance: bool) -> np.ndarray | None:
            return run.backend.relative_cov(c, n, run.chain, covariance)

        for s, c, P in run.loops.candidates(self.submaps, i, run.G, relative):
            own = diag["score"][k] if diag["matched"][k] else 1.0
            constraint = run.loops.try_close(self.submaps[s], i, c, P, beams.points, Ln, run.G, own)
            if constraint is not None:
                found.append(constraint)
            run.dense.pop(s, None)  # the last loop.cache_submaps submaps read stay dense, the others packed only
            run.dense[s] = None
            while len(run.dense) > self.params.loop.cache_submaps:
                self.submaps[run.dense.popitem(last=False)[0]].release()
        return found

    def _close_loops(self, run: _Run, i: int, k: int, found: list) -> None:
        """The ``found`` loops (and a false loop, when one is due by scan k) verified (``loop.verify``) and the graph's
        loops updated; ``run.G`` (N, 3) refreshed by iSAM2."""
        if len(run.false_loops) < len(run.false_at) and k >= run.false_at[len(run.false_loops)]:
            false = self._false_loop(i, run.G)
            if false is not None:
                found.append((("false", len(run.false_loops)), *false))
                run.false_loops.append((i, false[0]))
        if not found:
            return
        loops = {key: (c, i, z, cov) for key, c, z, cov in found}
        if run.consistent is None:
            run.G = run.backend.set_loops(loops, [])
            return
        for key, (c, _, z, cov) in loops.items():
            run.consistent.add(c, i, z, cov)
            run.vertex_key.append(key)
            self._set_test(run, key, "consistency")
        clique = {run.vertex_key[v] for v in run.consistent.clique}
        committed = set(run.backend.loops)
        add, remove = clique - committed, committed - clique
        for key in remove:
            self._set_test(run, key, "consistency")
        for key in add:
            self._set_test(run, key, "")
        if add or remove:
            edges = {key: loops.get(key) or self._vertex_loop(run, key) for key in add}
            run.G = run.backend.set_loops(edges, sorted(remove, key=str))

    @staticmethod
    def _set_test(run: _Run, key, test: str) -> None:
        """The test that rejects the loop ``key`` ('' accepted); the injected false loops are not in the record."""
        if isinstance(key, int):
            run.loops.record.test[key] = test

    @staticmethod
    def _vertex_loop(run: _Run, key) -> tuple:
        """(a, n, z, Σ) of the loop ``key`` met earlier by the consistency test."""
        v, pcm = run.vertex_key.index(key), run.consistent
        return int(pcm.a[v]), int(pcm.n[v]), pcm.z[v], pcm.cov[v]

    def _scan_poses(self, run: _Run, G: np.ndarray):
        """One world pose per scan (K, 3), G_{i(k)} ⊕ (L_{i(k)}⁻¹ ⊕ L_k) from the optimised node poses G (N, 3), then
        refined between the nodes (``refine.neighbours`` > 0); returns the poses and the refinement's report."""
        p = self.params
        Ln = np.asarray(run.L)
        i_k = np.maximum(run.node_of_scan, 0)
        poses = compose(G[i_k], between(Ln[i_k], run.local))
        refinement = None
        if p.refine.neighbours and run.L:
            with run.timed("optimisation"):
                nodes = np.asarray(run.node_scan)
                hanging = [
                    (
                        int(nodes[i_k[k]]),
                        k,
                        between(Ln[i_k[k]], run.local[k]),
                        self._front_end_cov(run.local[k], run.match_cov[k], run.match_info[k], run.odo_cov[k]),
                    )
                    for k in range(nodes[0] + 1, run.K)
                    if nodes[i_k[k]] != k
                ]
                poses, refinement = refine_scans(poses, nodes, hanging, run.pairs, p.robust_kernel)
        return poses, refinement

    def _estimate(self, sequence: Sequence, run: _Run, G: np.ndarray, poses: np.ndarray, report, refinement):
        """The estimate (scan poses (K, 3) at the scan stamps) with the diagnostics and meta; ``self.pose_graph`` and
        ``self.map`` (re-rendered from the optimised node poses G (N, 3)) set."""
        p, diag = self.params, run.diag
        self.pose_graph = run.backend.pose_graph(sequence.name, G)
        self.map = self._render(G, run.node_scan, run.scans, run.front.limit)
        diag.update(run.loops.record.arrays())
        diag["node_scan"] = np.asarray(run.node_scan, dtype=np.int64)
        diag["front_end_poses"] = run.local  # the poses before loop closure, one per scan
        diag["false_loop_node"], diag["false_loop_anchor"] = (
            np.asarray(v, dtype=np.int64).reshape(-1) for v in (zip(*run.false_loops) if run.false_loops else ([], []))
        )
        accepted = diag["loop_accepted"]
        meta = {
            "params": p.canonical(),
            "scans": int(run.K),
            "nodes": len(run.L),
            "submaps": len(self.submaps),
            "loop_candidates": int(accepted.size),
            "loop_closures": int(accepted.sum()),
            "loop_rejected": int((~accepted).sum()),
            "loop_rejected_by": run.loops.record.rejected_by(),
            "loop_verify": p.loop.verify,
            "false_loops": len(run.false_loops),
            "seconds": run.seconds,
            "optimisation": report,
            "refinement": refinement,
            "odometry_stalled_scans": int(run.front.stalled.sum()),
            "map_shape": list(self.map.shape),
            "map_origin": self.map.origin.tolist(),
        }
        return Estimate(
            method="laser_slam",
            t=run.scans.t.copy(),
            poses=poses,
            step_time=run.step_time,
            diagnostics=diag,
            meta=meta,
        )

    def _front_end_cov(self, matched: np.ndarray, C: np.ndarray, info: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """Covariance of a front-end relative pose ending at the scan ``matched`` (its front-end pose), matched with
        covariance C and information I (front-end frame), its interval's odometry covariance Q (the scan's frame; NaN:
        none): fuse(Q, Rᵀ I R) (:mod:`.interval`), or without Q, C rotated into the matched scan's frame — where
        GTSAM's BetweenFactorPose2 measures its error, z⁻¹ x_a⁻¹ x_b —; plus the floors (module docstring)."""
        p = self.params
        R = _rotation(matched[2])
        cov = fuse(Q, R.T @ info @ R) if np.all(np.isfinite(Q)) else R.T @ C @ R
        return cov + np.diag(np.square([p.sigma_translation, p.sigma_translation, p.sigma_rotation]))

    def _false_loop(self, n: int, G: np.ndarray) -> tuple[int, np.ndarray, np.ndarray] | None:
        """A deliberately false loop for node n (module docstring): (node c, z, Σ), or None while no finished
        submap's node lies farther than half ``loop.false_loop_distance``."""
        p = self.params.loop
        nodes = np.array([c for s in self.submaps if s.finished for c in s.nodes], dtype=np.int64)
        d = np.hypot(*(G[nodes, :2] - G[n, :2]).T) if nodes.size else np.zeros(0)
        if not np.any(d > p.false_loop_distance / 2):
            return None
        c = int(nodes[np.argmin(np.where(d > p.false_loop_distance / 2, np.abs(d - p.false_loop_distance), np.inf))])
        z = np.array([0.0, 0.0, float(wrap_angle(G[n, 2] - G[c, 2]))])
        return c, z, np.diag(np.square([p.sigma_translation, p.sigma_translation, p.sigma_rotation]))

    def _render(self, G, node_scan, scans, limit) -> OccupancyGrid:
        """The finest grid re-rendered from every node's scan at its optimised pose."""
        p = self.params
        grid = OccupancyGrid(
            resolution=p.pyramid.resolution, cells=p.pyramid.cells, width=1, height=1, origin=tuple(G[0, :2])
        )
        front = FrontEnd(p.frontend, scans)
        for i, k in enumerate(node_scan):
            beams = front.beams(k)
            grid.integrate(
                beams.r[beams.mapped],
                beams.a[beams.mapped],
                G[i],
                scans.mount,
                max_range=limit,
                clear_range=p.frontend.clear_range,
            )
        grid.release_scratch()  # the tracing's int64 scratch, twice the map's size
        return grid


#: σ [m] a pairwise factor states along a degenerate direction (no information: the hanging factor decides)
_UNCONSTRAINED = 1e3


def _rotation(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _in_end_frame(cov: np.ndarray, theta: float) -> np.ndarray:
    """A relative pose's covariance (3, 3) expressed in its start's frame, rotated into its end's frame (heading θ
    relative to the start), where GTSAM's BetweenFactorPose2 measures its error: blockdiag(R(θ), 1)ᵀ Σ blockdiag(R(θ), 1)."""
    R = _rotation(theta)
    return R.T @ cov @ R


def _information(res) -> np.ndarray:
    """The match's information (3, 3): the matcher's own (``info["information"]``, Gauss-Newton: without its prior,
    the degenerate direction projected out), else its covariance's inverse, zero where that is not finite."""
    if "information" in res.info:
        return res.info["information"]
    if not np.all(np.isfinite(res.cov)):
        return np.zeros((3, 3))
    return np.linalg.pinv(res.cov, hermitian=True)


def _finite(cov: np.ndarray) -> np.ndarray:
    """The matcher's covariance, or zero where the match gave none (the floor then carries the factor)."""
    return cov if np.all(np.isfinite(cov)) else np.zeros((3, 3))
