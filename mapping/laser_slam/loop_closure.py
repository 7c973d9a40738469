"""Loop-closure search of laser graph SLAM: which finished submaps a new node is matched against, and the match.

Candidates and windows come from the graph's marginal covariance: P_cn (3, 3), the covariance of the relative pose
X_c⁻¹ X_n of node n and a submap's node c in n's frame, from the joint marginal of the two nodes
(:meth:`.backend.Backend.relative_cov`). With κ² the χ²₃ quantile of ``window_confidence``,
the χ² ellipsoid of P_cn projects onto each axis within ± κσ, so the branch-and-bound window is

    linear ± clip(κ √λ_max(P_cn[:2, :2]), min_linear_window, linear_window),  angular ± clip(κ √P_cn[2, 2], …)

(the caps bound the search's cost). A finished submap s (not among the ``exclude_recent`` latest) is a candidate
when its node c nearest to node n (in the estimate) could be within ``overlap`` of it: the part of the distance
beyond ``overlap`` is inside the window (‖Δ‖ − overlap ≤ linear half-width); the nearest ``max_candidates`` are
tried. The window thus widens with the path travelled since the last closure and collapses once a loop closes —
down to its floors, which are shipped at the caps (a fixed ± 5 m, ± 0.5 rad window). On the simulated corridor loop
the marginal windows lose the drive (ATE 0.64 → 1.87 m over 20 drives): not because the sequential factors'
covariance is overconfident (the chain's ± κσ holds the front end's true drift over ≥ 30 nodes), but because a false
loop accepted online (an alias 6 m along the corridor, its true place outside the submap) collapses the marginal
around the wrong place, inside which every later match is an alias (research/method/loop_verification.md). While the
floors reach the caps (:attr:`LoopCloser.fixed`) no marginal is computed: every window is the caps.

Match. With c the submap's node nearest to node n in the current estimate, the guess of node n in the submap's
(front-end) frame is M̂ = L_c ⊕ (G_c⁻¹ ⊕ G_n). Branch and bound
(:class:`~slamarena.mapping.scan_matching.correlative.BranchAndBoundMatcher`) searches the window around it on
pyramid level ``level`` of the submap, against the submap's likelihood grid and
max-pyramid — computed once per submap for its whole extent and kept in a small least-recently-used cache —;
Gauss-Newton on the submap's pyramid refines the lattice pose to M. The branch-and-bound search uses the end
points within ``max_range`` (the angular step is set by the farthest point), thinned to one per ``voxel``
cell (its cost is linear in the points; the refinement uses all), and prunes below ``min_search_score`` (mean
log-likelihood per point, as Cartographer's min_score): a candidate with nothing above it is rejected unrefined.
The match is accepted when the refined
pose's score (the mean occupancy probability under the scan's end points on the finest level, 0 … 1) is at
least ``score_ratio`` times the score of the same scan against its own submap in the front end (a scan fits
an old map about as well as the one it was just matched to, or not at all: the ratio carries over between
environments and sensors where an absolute score does not — FR-Clinic's scans score 0.48 in the front end where
Intel's score 0.75), and at least ``min_score``. The loop constraint is z = L_c⁻¹ ⊕ M between node n and the submap's node c nearest to the
matched pose M: a submap is consistent near each of its nodes, not across its whole extent (the front end drifts
while it builds it), so a constraint to its first node would carry that drift over the lever arm between them.
Its covariance is the spread of
the exhaustive correlative response (Olson 2009) within ± ``covariance_window`` and ± ``covariance_angle``
of the found pose — wide enough that a corridor, where a scan fits anywhere along the walls, shows up as a long
axis the graph then hardly trusts — rotated into the frame of the matched pose M (z's end, where GTSAM's
BetweenFactorPose2 measures its error), plus the floors ``sigma_*``² on its diagonal.

Uniqueness: a place that repeats (identical rooms along a corridor) matches as well 4 m along as at its own place,
and the branch-and-bound search returns whichever scores a little higher. The exhaustive response S(x, y, θ) (the
summed log-likelihood of the thinned end points) over the whole translation window and ± ``covariance_angle`` around
the found pose, maximised over θ, is thresholded at its maximum minus ``ambiguity`` · (points): a match is unique
when the translations above the threshold form one connected region (8-connected cells). A long corridor gives
one elongated region (the covariance then says which way the match is weak); repeated rooms give one island per
room in the window, and the candidate is rejected (``ambiguous``). Once a unique place (a corner) closes a loop the
windows shrink below the period and the rooms become unique too. Only the superlevel set is needed, so the response is
evaluated only in the tiles of 8 × 8 shifts whose max-pyramid bound (the branch and bound's) reaches S(found pose) −
``ambiguity`` · (points) (:func:`_best_over_angles`): the set, and so the verdict, is the exhaustive one's exactly.

Which matches then join the graph is decided by the verification (:mod:`.consistency`, :mod:`.slam`). There is no
χ² gate of the match against the estimate's prediction inside the window: the sequential factors' covariance
(the matcher's Laplace covariance plus 2 cm / 5 mrad floors per node) is overconfident where the front end slips by
0.2–0.3 m in one step, and such a gate rejected true loops at d² = 17 … 86 for a 99.9 % threshold of 16.3, after
which no loop closed until the windows had grown (research/notebook/2026-11-28-loop-verification.md).

Every candidate is recorded with the test that rejected it (:data:`TESTS`): ``search`` (nothing in the window above
the branch-and-bound floor), ``score`` (the refined score below the acceptance test), ``ambiguous`` (another place
in the window matches nearly as well), ``consistency`` (not in the largest pairwise-consistent set at the end), ``gnc`` (GNC's final
weight below ½); accepted loops have none.

The names are those of :class:`LoopClosureParams`, the ``loop`` of laser graph SLAM's parameters.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numba import njit
from pydantic import NonNegativeFloat, NonNegativeInt, PositiveFloat, PositiveInt
from scipy.ndimage import label
from scipy.stats import chi2

from slamarena.datasets.geometry import between, compose
from slamarena.params import Field, Params

from ..scan_matching.correlative import BranchAndBoundMatcher, CorrelativeMatcher, _node_score
from ..scan_matching.gauss_newton import GaussNewtonMatcher

__all__ = ["TESTS", "LoopCloser", "LoopClosureParams", "LoopRecord"]

#: the tests a loop candidate can fail, in the order they are applied
TESTS = ("search", "score", "ambiguous", "consistency", "gnc")


class LoopClosureParams(Params):
    """The loop-closure search (module docstring): when and where to search, the branch-and-bound match, the
    acceptance test, the loop factor's covariance; and the robustness study's deliberately false loops
    (:mod:`.slam`)."""

    enabled: bool = Field(
        True, description="search for loop closures (False: the graph holds the front end's chain only)"
    )
    search_every: PositiveInt = Field(3, description="search for loop closures at every this-many-th node")
    overlap: NonNegativeFloat = Field(
        3.0,
        description="a submap is a candidate when its nearest node could be this close to the node [m] (scans overlap)",
    )
    window_confidence: float = Field(
        0.999,
        gt=0.0,
        lt=1.0,
        description="the search window holds the relative pose's marginal χ²₃ ellipsoid of this probability",
    )
    min_linear_window: PositiveFloat = Field(
        5.0,
        description="least half-width of the loop search in translation [m]; the shipped 5 m (= the cap) keeps the "
        "window fixed until the sequential factors' covariance is honest (research/method/loop_verification.md)",
    )
    min_angular_window: PositiveFloat = Field(
        0.5, description="least half-width of the loop search in rotation [rad] (shipped: the cap, as above)"
    )
    max_candidates: PositiveInt = Field(3, description="most submaps tried per search (the nearest)")
    exclude_recent: NonNegativeInt = Field(
        1, description="latest finished submaps not searched (the front end still overlaps them)"
    )
    linear_window: PositiveFloat = Field(
        5.0, description="most half-width of the loop search in translation [m] (cost)"
    )
    angular_window: PositiveFloat = Field(
        0.5, description="most half-width of the loop search in rotation [rad] (cost)"
    )
    level: NonNegativeInt = Field(1, description="pyramid level of the branch-and-bound loop search")
    voxel: NonNegativeFloat = Field(
        0.1, description="the loop search's end points thinned to one per cell of this side [m] (0: all)"
    )
    max_range: PositiveFloat = Field(15.0, description="the loop search uses the end points within this range [m]")
    min_search_score: float = Field(
        -2.5,
        le=0.0,
        description="branch-and-bound floor: mean log-likelihood per point below which a candidate is rejected unrefined",
    )
    min_score: float = Field(
        0.3,
        gt=0.0,
        lt=1.0,
        description="accept a loop only when the refined match's mean occupancy probability is at least this …",
    )
    score_ratio: float = Field(
        0.9, gt=0.0, le=1.5, description="… and at least this times the node's own front-end match score"
    )
    ambiguity: NonNegativeFloat = Field(
        0.3,
        description="reject a match when another region of the window scores within this much mean log-likelihood per "
        "point of it",
    )
    covariance_window: PositiveFloat = Field(
        1.0, description="half-width of the response whose spread is a loop's covariance, translation [m]"
    )
    covariance_angle: PositiveFloat = Field(0.05, description="… and rotation [rad]")
    sigma_translation: PositiveFloat = Field(0.05, description="added to a loop factor's translation σ [m]")
    sigma_rotation: PositiveFloat = Field(0.01, description="added to a loop factor's rotation σ [rad]")
    verify: Literal["pcm", "gnc", "none"] = Field(
        "gnc",
        description="which unique matches join the graph: all, GNC's truncated least squares deciding in the final "
        "solve (gnc); the largest pairwise-consistent set (pcm); all, the robust kernel alone (none)",
    )
    consistency_confidence: float = Field(
        0.999, gt=0.0, lt=1.0, description="PCM: two loops are consistent within the χ²₃ quantile of this probability"
    )
    cache_submaps: PositiveInt = Field(
        3,
        description="submaps whose likelihood pyramids are kept for the loop search (a search reads a few; 3 bounds "
        "the memory of a long log: research/notebook/2026-11-28-rbpf-scale.md)",
    )
    false_loops: NonNegativeInt = Field(
        0,
        description="robustness study only: add this many deliberately false loop closures, spread evenly over the log",
    )
    false_loop_distance: PositiveFloat = Field(
        5.0, description="a false loop claims its node sits at the node about this far away [m]"
    )


@dataclass
class LoopRecord:
    """Every candidate tried: node, submap, anchor node, the branch-and-bound score (mean log-likelihood per point) and
    nodes scored, the refined score, the window's linear half-width [m], the test that rejected it
    ('' while it is accepted; :data:`TESTS`), CPU time [s], the constraint z (3,) and its covariance (3, 3)."""

    node: list = field(default_factory=list)
    submap: list = field(default_factory=list)
    anchor: list = field(default_factory=list)
    search_score: list = field(default_factory=list)
    search_nodes: list = field(default_factory=list)
    score: list = field(default_factory=list)
    window: list = field(default_factory=list)
    test: list = field(default_factory=list)
    seconds: list = field(default_factory=list)
    z: list = field(default_factory=list)
    cov: list = field(default_factory=list)

    _NAMES = ("node", "submap", "anchor", "search_score", "search_nodes", "score", "window", "test", "seconds")

    def add(self, *values, z, cov) -> int:
        """Append one candidate (the fields of ``_NAMES`` in order, then z and Σ); returns its index."""
        for name, value in zip(self._NAMES, values, strict=True):
            getattr(self, name).append(value)
        self.z.append(z)
        self.cov.append(cov)
        return len(self.node) - 1

    def rejected_by(self) -> dict[str, int]:
        """How many candidates each test rejected (:data:`TESTS`)."""
        return {t: self.test.count(t) for t in TESTS}

    def arrays(self) -> dict[str, np.ndarray]:
        test = np.asarray(self.test, dtype=str)
        return {
            "loop_node": np.asarray(self.node, dtype=np.int64),
            "loop_submap": np.asarray(self.submap, dtype=np.int64),
            "loop_anchor": np.asarray(self.anchor, dtype=np.int64),
            "loop_search_score": np.asarray(self.search_score, dtype=float),
            "loop_search_nodes": np.asarray(self.search_nodes, dtype=np.int64),
            "loop_score": np.asarray(self.score, dtype=float),
            "loop_window": np.asarray(self.window, dtype=float),
            "loop_test": test,
            "loop_accepted": test == "",
            "loop_seconds": np.asarray(self.seconds, dtype=float),
            "loop_z": np.asarray(self.z, dtype=float).reshape(-1, 3),
        }


#: the uniqueness test bounds tiles of (2^depth)² translations by the max-pyramid level of this depth
_TILE_DEPTH = 3


@njit(cache=True)
def _best_over_angles(pyramid, depth, ix, iy, w, slack):
    """best[b + w, a + w] = max_k S(k, a, b) (2w + 1, 2w + 1), S the summed likelihood of the points' cells ix, iy
    (K, N) at angle k shifted by (a, b), |a|, |b| ≤ w — exact wherever it reaches max S − ``slack``, −inf in the
    tiles of 2^depth × 2^depth shifts whose max-pyramid bound (``pyramid[depth]``, each cell the maximum of the
    2^depth × 2^depth cells from it) lies below S(centre angle, 0, 0) − slack: no shift in them can reach max S −
    slack (bound ≥ S term by term, and float sums in the same order keep it). The superlevel set is the exhaustive
    response's, at a fraction of the lookups."""
    K = ix.shape[0]
    n = 2 * w + 1
    best = np.full((n, n), -np.inf)
    floor = _node_score(pyramid[0], ix[K // 2], iy[K // 2], 0, 0) - slack
    step = 2**depth
    for k in range(K):
        for tb in range(-w, w + 1, step):
            for ta in range(-w, w + 1, step):
                if _node_score(pyramid[depth], ix[k], iy[k], ta, tb) < floor:
                    continue
                for b in range(tb, min(tb + step, w + 1)):
                    for a in range(ta, min(ta + step, w + 1)):
                        v = _node_score(pyramid[0], ix[k], iy[k], a, b)
                        if v > best[b + w, a + w]:
                            best[b + w, a + w] = v
    return best


def voxel_filter(points: np.ndarray, size: float) -> np.ndarray:
    """One point per ``size`` × ``size`` cell (the first of each), in the points' order."""
    if size <= 0 or len(points) == 0:
        return points
    cells = np.floor(points / size).astype(np.int64)
    _, first = np.unique(cells[:, 0] * 2_000_003 + cells[:, 1], return_index=True)
    return points[np.sort(first)]


class _Precomputed:
    """A correlative matcher that searches a precomputed whole-submap likelihood grid and max-pyramid (``active``)."""

    active: dict | None = None

    def _grids(self, maps, depth, guess, reach):
        return self.active


class _SubmapBranchAndBound(_Precomputed, BranchAndBoundMatcher):
    """The wide branch-and-bound search."""


class _SubmapResponse(_Precomputed, CorrelativeMatcher):
    """The exhaustive response around the found pose, whose spread is the loop constraint's covariance."""


class LoopCloser:
    """Candidate selection, windows, matching and the gate (module docstring; :class:`LoopClosureParams`)."""

    def __init__(self, params: LoopClosureParams):
        self.p = params
        self.kappa = float(np.sqrt(chi2.ppf(params.window_confidence, 3)))
        self.bnb = _SubmapBranchAndBound(
            linear_window=params.linear_window,
            angular_window=params.angular_window,
            level=params.level,
            refine=False,
            min_score=params.min_search_score,
        )
        self.response = _SubmapResponse(
            linear_window=params.covariance_window,
            angular_window=params.covariance_angle,
            level=params.level,
        )
        self.modes = _SubmapResponse(
            linear_window=params.linear_window, angular_window=params.covariance_angle, level=params.level
        )
        self.gn = GaussNewtonMatcher()
        self._cache: OrderedDict[int, dict] = OrderedDict()
        self.record = LoopRecord()

    @property
    def fixed(self) -> bool:
        """Whether the floors reach the caps (as shipped): every window is then the caps, and no marginal is needed."""
        p = self.p
        return p.min_linear_window >= p.linear_window and p.min_angular_window >= p.angular_window

    def window(self, P: np.ndarray | None) -> tuple[float, float]:
        """The branch-and-bound half-widths (translation [m], rotation [rad]) of the relative covariance P (3, 3);
        the caps when the windows are :attr:`fixed` (P None)."""
        p = self.p
        if P is None:
            return p.linear_window, p.angular_window
        sigma = np.sqrt(max(np.linalg.eigvalsh(P[:2, :2])[-1], 0.0))
        linear = float(np.clip(self.kappa * sigma, p.min_linear_window, p.linear_window))
        angular = float(np.clip(self.kappa * np.sqrt(max(P[2, 2], 0.0)), p.min_angular_window, p.angular_window))
        return linear, angular

    def candidates(self, submaps, n: int, G: np.ndarray, relative) -> list[tuple[int, int, np.ndarray | None]]:
        """The finished submaps to try for node n, nearest first: (submap index, its node c nearest to node n,
        P_cn (3, 3), None when the windows are :attr:`fixed`); ``relative(c, n, covariance)`` is P_cn (None when
        ``covariance`` is False)."""
        p = self.p
        finished = [s for s in submaps if s.finished]
        pool = finished[: max(len(finished) - p.exclude_recent, 0)]
        out = []
        for s in pool:
            nodes = np.asarray(s.nodes)
            d = np.hypot(*(G[nodes, :2] - G[n, :2]).T)
            if d.min() - p.overlap > p.linear_window:  # beyond any window: no marginal needed
                continue
            c = int(nodes[np.argmin(d)])
            P = relative(c, n, not self.fixed)  # None when fixed: the joint marginal costs a factorisation of the graph
            if d.min() - p.overlap <= self.window(P)[0]:
                out.append((d.min(), s.index, c, P))
        out.sort(key=lambda t: t[0])
        return [(s, c, P) for _, s, c, P in out[: p.max_candidates]]

    def release(self) -> None:
        """Drop the cached likelihood grids of the loop search (no loop is searched again: memory at a log's end)."""
        self._cache.clear()

    def _precomputed(self, submap) -> dict:
        if submap.index in self._cache:
            self._cache.move_to_end(submap.index)
            return self._cache[submap.index]
        grid = submap.maps.levels[min(self.p.level, len(submap.maps.levels) - 1)]
        w = int(
            np.ceil(self.p.linear_window / grid.params.resolution - 1e-9)
        )  # the widest window's, whatever this one's
        depth = int(np.ceil(np.log2(2 * w + 1))) if w > 0 else 0
        cache = dict(BranchAndBoundMatcher._grids(self.bnb, submap.maps, depth, np.zeros(3), 1e12))  # the whole submap
        self._cache[submap.index] = cache
        while len(self._cache) > self.p.cache_submaps:
            self._cache.popitem(last=False)
        return cache

    def _regions(self, submap, points: np.ndarray, pose: np.ndarray, linear: float) -> int:
        """How many separate regions of the translation window ± ``linear`` score within ``ambiguity`` per point of the
        best (module docstring, "Uniqueness"); ``points``: the thinned end points, ``pose``: the found pose."""
        m = self.modes
        m.params = m.params.model_copy(update={"linear_window": linear})
        grid = submap.maps.levels[min(self.p.level, len(submap.maps.levels) - 1)]
        dth, na = m._angles(grid, points)
        cache = m._grids(submap.maps, 0, pose, 0.0)
        offsets = np.arange(-na, na + 1) * dth
        ix, iy = m._cells(grid, cache["pad"] - cache["corner"], points, pose, pose[2] + offsets)
        slack = self.p.ambiguity * len(points)
        pyramid = cache["pyramid"]
        best = _best_over_angles(pyramid, min(_TILE_DEPTH, len(pyramid) - 1), ix, iy, m._w(grid), slack)
        return int(label(best >= best.max() - slack, structure=np.ones((3, 3)))[1])

    def try_close(
        self,
        submap,
        n: int,
        c: int,
        P: np.ndarray,
        points: np.ndarray,
        L: np.ndarray,
        G: np.ndarray,
        own_score: float,
    ) -> tuple[int, int, np.ndarray, np.ndarray] | None:
        """Match node n's scan end points (robot frame) against ``submap`` within the window of P = P_cn (3, 3) around
        the guess from its node c; (record index, node c', z, Σ) of a match that passes the score test and is unique,
        else None.

        ``own_score``: the score of node n's scan against the submap the front end matched it to."""
        tic = time.process_time()
        nodes = np.asarray(submap.nodes)
        guess = compose(L[c], between(G[c], G[n]))
        linear, angular = self.window(P)
        self.bnb.params = self.bnb.params.model_copy(update={"linear_window": linear, "angular_window": angular})
        self.bnb.active = self.response.active = self.modes.active = self._precomputed(submap)
        near = voxel_filter(points[np.hypot(points[:, 0], points[:, 1]) <= self.p.max_range], self.p.voxel)
        coarse = self.bnb.match(submap.maps, near, guess)
        nan3 = np.full(3, np.nan)
        if not np.isfinite(coarse.score):  # nothing in the window is worth refining
            values = (n, submap.index, c, float(coarse.score), int(coarse.iterations), np.nan, linear, "search")
            self.record.add(*values, time.process_time() - tic, z=nan3, cov=np.full((3, 3), np.nan))
            return None
        fine = self.gn.match(submap.maps, points, coarse.pose)
        scored = bool(
            fine.score >= max(self.p.min_score, self.p.score_ratio * own_score) and np.all(np.isfinite(fine.pose))
        )
        c = int(nodes[np.argmin(np.hypot(*(L[nodes, :2] - fine.pose[:2]).T))])  # whose part of the submap it matched
        z = between(L[c], fine.pose)
        spread = self.response.match(submap.maps, near, coarse.pose).cov if scored else np.full((3, 3), np.nan)
        cos, sin = np.cos(fine.pose[2]), np.sin(fine.pose[2])
        # world-aligned (the submap's frame) → node n's frame, z's end, where GTSAM's BetweenFactorPose2 measures its error
        R = np.array([[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]])
        cov = R @ spread @ R.T + np.diag(
            np.square([self.p.sigma_translation, self.p.sigma_translation, self.p.sigma_rotation])
        )
        test = "score" if not scored else "" if self._regions(submap, near, coarse.pose, linear) == 1 else "ambiguous"
        values = (n, submap.index, c, float(coarse.score), int(coarse.iterations), float(fine.score), linear, test)
        index = self.record.add(*values, time.process_time() - tic, z=z, cov=cov)
        return (index, c, z, cov) if test == "" else None
