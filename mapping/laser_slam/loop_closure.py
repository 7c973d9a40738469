"""Loop-closure search of laser graph SLAM: which finished submaps a new node is matched against, and the match.

Candidates. For node n (world estimate G_n) a finished submap s is a candidate when it is not among the
``exclude_recent`` latest finished submaps and its nearest node is within

    min_{c ∈ s} ‖G_c.xy − G_n.xy‖ ≤ r_s = search_radius + search_growth · d(s, n)

with d(s, n) the distance the front end travelled from the submap's last node to node n: odometry-like
drift grows with the path, so the older a submap the wider the search. At most ``max_candidates`` (the
nearest) are tried.

Match. With c the submap's node nearest to node n in the current estimate, the guess of node n in the submap's
(front-end) frame is M̂ = L_c ⊕ (G_c⁻¹ ⊕ G_n). Branch and bound
(:class:`~slamarena.mapping.scan_matching.correlative.BranchAndBoundMatcher`) searches ± ``linear_window`` and
± ``angular_window`` around it on pyramid level ``level`` of the submap, against the submap's likelihood grid and
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

The names are those of :class:`LoopClosureParams`, the ``loop`` of laser graph SLAM's parameters.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from pydantic import NonNegativeFloat, NonNegativeInt, PositiveFloat, PositiveInt

from slamarena.datasets.geometry import between, compose
from slamarena.params import Field, Params

from ..scan_matching.correlative import BranchAndBoundMatcher, CorrelativeMatcher
from ..scan_matching.gauss_newton import GaussNewtonMatcher

__all__ = ["LoopCloser", "LoopClosureParams", "LoopRecord"]


class LoopClosureParams(Params):
    """The loop-closure search (module docstring): when and where to search, the branch-and-bound match, the
    acceptance test, the loop factor's covariance; and the robustness study's deliberately false loops
    (:mod:`.slam`)."""

    enabled: bool = Field(
        True, description="search for loop closures (False: the graph holds the front end's chain only)"
    )
    search_every: PositiveInt = Field(3, description="search for loop closures at every this-many-th node")
    search_radius: NonNegativeFloat = Field(5.0, description="candidate submaps within this distance of the node [m] …")
    search_growth: NonNegativeFloat = Field(
        0.05, description="… plus this fraction of the distance travelled since the submap [1]"
    )
    max_candidates: PositiveInt = Field(3, description="most submaps tried per search (the nearest)")
    exclude_recent: NonNegativeInt = Field(
        1, description="latest finished submaps not searched (the front end still overlaps them)"
    )
    linear_window: PositiveFloat = Field(5.0, description="half-width of the loop search in translation [m]")
    angular_window: PositiveFloat = Field(0.5, description="half-width of the loop search in rotation [rad]")
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
    covariance_window: PositiveFloat = Field(
        1.0, description="half-width of the response whose spread is a loop's covariance, translation [m]"
    )
    covariance_angle: PositiveFloat = Field(0.05, description="… and rotation [rad]")
    sigma_translation: PositiveFloat = Field(0.05, description="added to a loop factor's translation σ [m]")
    sigma_rotation: PositiveFloat = Field(0.01, description="added to a loop factor's rotation σ [rad]")
    cache_submaps: PositiveInt = Field(8, description="submaps whose likelihood pyramids are kept for the loop search")
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
    nodes scored, the refined score, accepted, CPU time [s], the constraint."""

    node: list = field(default_factory=list)
    submap: list = field(default_factory=list)
    anchor: list = field(default_factory=list)
    search_score: list = field(default_factory=list)
    search_nodes: list = field(default_factory=list)
    score: list = field(default_factory=list)
    accepted: list = field(default_factory=list)
    seconds: list = field(default_factory=list)
    z: list = field(default_factory=list)

    def add(self, node, submap, anchor, search_score, search_nodes, score, accepted, seconds, z) -> None:
        for name, value in zip(
            ("node", "submap", "anchor", "search_score", "search_nodes", "score", "accepted", "seconds", "z"),
            (node, submap, anchor, search_score, search_nodes, score, accepted, seconds, z),
        ):
            getattr(self, name).append(value)

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "loop_node": np.asarray(self.node, dtype=np.int64),
            "loop_submap": np.asarray(self.submap, dtype=np.int64),
            "loop_anchor": np.asarray(self.anchor, dtype=np.int64),
            "loop_search_score": np.asarray(self.search_score, dtype=float),
            "loop_search_nodes": np.asarray(self.search_nodes, dtype=np.int64),
            "loop_score": np.asarray(self.score, dtype=float),
            "loop_accepted": np.asarray(self.accepted, dtype=bool),
            "loop_seconds": np.asarray(self.seconds, dtype=float),
            "loop_z": np.asarray(self.z, dtype=float).reshape(-1, 3),
        }


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
    """Candidate selection and matching (module docstring; :class:`LoopClosureParams`)."""

    def __init__(self, params: LoopClosureParams):
        self.p = params
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
        self.gn = GaussNewtonMatcher()
        self._cache: OrderedDict[int, dict] = OrderedDict()
        self.record = LoopRecord()

    def candidates(self, submaps, n: int, G: np.ndarray, travelled: np.ndarray) -> list[int]:
        """Indices of the finished submaps to try for node n (nearest first)."""
        p = self.p
        finished = [s for s in submaps if s.finished]
        pool = finished[: max(len(finished) - p.exclude_recent, 0)]
        if not pool:
            return []
        d = np.array([np.hypot(*(G[s.nodes, :2] - G[n, :2]).T).min() for s in pool])
        radius = p.search_radius + p.search_growth * (travelled[n] - travelled[[s.nodes[-1] for s in pool]])
        near = np.flatnonzero(d <= radius)
        return [pool[i].index for i in near[np.argsort(d[near])][: p.max_candidates]]

    def _precomputed(self, submap) -> dict:
        if submap.index in self._cache:
            self._cache.move_to_end(submap.index)
            return self._cache[submap.index]
        grid = submap.maps.levels[min(self.p.level, len(submap.maps.levels) - 1)]
        w = self.bnb._w(grid)
        depth = int(np.ceil(np.log2(2 * w + 1))) if w > 0 else 0
        cache = dict(BranchAndBoundMatcher._grids(self.bnb, submap.maps, depth, np.zeros(3), 1e12))  # the whole submap
        self._cache[submap.index] = cache
        while len(self._cache) > self.p.cache_submaps:
            self._cache.popitem(last=False)
        return cache

    def try_close(
        self, submap, n: int, points: np.ndarray, L: np.ndarray, G: np.ndarray, own_score: float
    ) -> tuple[int, np.ndarray, np.ndarray] | None:
        """Match node n's scan end points (robot frame) against ``submap``; (node c, z, Σ) of an accepted loop, else None.

        ``own_score``: the score of node n's scan against the submap the front end matched it to."""
        tic = time.process_time()
        nodes = np.asarray(submap.nodes)
        c = nodes[
            np.argmin(np.hypot(*(G[nodes, :2] - G[n, :2]).T))
        ]  # the submap's node nearest to node n, as estimated
        guess = compose(L[c], between(G[c], G[n]))
        self.bnb.active = self.response.active = self._precomputed(submap)
        near = voxel_filter(points[np.hypot(points[:, 0], points[:, 1]) <= self.p.max_range], self.p.voxel)
        coarse = self.bnb.match(submap.maps, near, guess)
        if not np.isfinite(coarse.score):  # nothing in the window is worth refining
            self.record.add(
                n,
                submap.index,
                c,
                float(coarse.score),
                int(coarse.iterations),
                float("nan"),
                False,
                time.process_time() - tic,
                np.full(3, np.nan),
            )
            return None
        fine = self.gn.match(submap.maps, points, coarse.pose)
        accepted = bool(
            fine.score >= max(self.p.min_score, self.p.score_ratio * own_score) and np.all(np.isfinite(fine.pose))
        )
        c = nodes[
            np.argmin(np.hypot(*(L[nodes, :2] - fine.pose[:2]).T))
        ]  # the node whose part of the submap the scan matched
        z = between(L[c], fine.pose)
        spread = self.response.match(submap.maps, near, coarse.pose).cov if accepted else np.full((3, 3), np.nan)
        cos, sin = np.cos(fine.pose[2]), np.sin(fine.pose[2])
        # world-aligned (the submap's frame) → node n's frame, z's end, where GTSAM's BetweenFactorPose2 measures its error
        R = np.array([[cos, sin, 0.0], [-sin, cos, 0.0], [0.0, 0.0, 1.0]])
        cov = R @ spread @ R.T + np.diag(
            np.square([self.p.sigma_translation, self.p.sigma_translation, self.p.sigma_rotation])
        )
        self.record.add(
            n,
            submap.index,
            c,
            float(coarse.score),
            int(coarse.iterations),
            float(fine.score),
            accepted,
            time.process_time() - tic,
            z,
        )
        return (int(c), z, cov) if accepted else None
