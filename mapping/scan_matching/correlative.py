"""Correlative scan matching (Olson 2009) and its branch-and-bound form (Hess et al. 2016).

Likelihood grid. From the map's occupied cells (``p > occupied_threshold``) and the
Euclidean distance ``d`` of every cell to the nearest one, each cell stores the
log-likelihood of a scan end point falling in it,

    G = log( p_floor + (1 − p_floor) · exp(−d² / 2σ²) )

(a Gaussian smoothing of the obstacles, with a floor for points that hit nothing mapped).

Search space. Around the guess ``(x, y, θ)``: translations ``(a, b)·res`` for integers
``|a|, |b| ≤ w = ⌈linear_window / res⌉`` and rotations ``θ + k·δθ``, ``|k| ≤ ⌈angular_window / δθ⌉``
with ``δθ = arccos(1 − res² / 2 r_max²)`` (the farthest point moves at most one cell, as in
Cartographer) unless given. A candidate's score is ``S = Σ_i G[cell(R(θ_k) s_i + t) + (a, b)]``;
``score`` in the result is ``S / N`` (mean log-likelihood per point).

Exhaustive search (:class:`CorrelativeMatcher`) evaluates every candidate; the response gives
the covariance as in Olson (2009, §IV): weights ``w_j = exp(S_j − S_max)``,

    μ = Σ w_j ξ_j / Σ w_j,    Σ = Σ w_j (ξ_j − μ)(ξ_j − μ)ᵀ / Σ w_j  + diag(res², res², δθ²)/12

(the last term is the variance of the discretisation).

Branch and bound (:class:`BranchAndBoundMatcher`): precomputed grids ``P_h[y, x] = max G`` over
the ``2^h × 2^h`` block starting at ``(x, y)``. A node ``(h, a, b, k)`` stands for the
offsets ``a … a + 2^h − 1``, ``b … b + 2^h − 1``; its score with ``P_h`` bounds the score of
every candidate below it, so a depth-first search from the top level that visits children
best-first and prunes nodes whose bound does not beat the best leaf found returns the same
optimum as the exhaustive search. Its covariance comes from the exhaustive response in a
small window (``± covariance_cells`` cells and angle steps) around the optimum.

The grids are float32 (scores are summed in float64) and padded by one ring of floor cells: a point outside the
array is clamped to its edge, which reads the floor on P_0 and an upper bound on every P_h.

Both return a lattice pose (whole cells, whole angle steps). ``refine=True`` polishes it with
the Gauss-Newton matcher on the map pyramid, as Cartographer follows its branch and bound with
its Ceres matcher: the wide, global search picks the basin, Gauss-Newton the sub-cell optimum.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import NonNegativeFloat, NonNegativeInt, PositiveFloat, PositiveInt

from slamarena.datasets.geometry import wrap_angle
from slamarena.params import Field, Params

from ..occupancy_grid import probability as _probability
from . import MatchResult

__all__ = [
    "CorrelativeMatcher",
    "CorrelativeMatcherParams",
    "BranchAndBoundMatcher",
    "BranchAndBoundMatcherParams",
    "likelihood_grid",
]

_BLOCK = 64


def likelihood_grid(grid, sigma: float, p_floor: float, box: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """``G`` (rows = y) of the module docstring for an :class:`OccupancyGrid`, or for its cells
    ``box = (ix0, iy0, ix1, iy1)`` (half-open); obstacles up to ``4σ`` outside the box count."""
    from scipy.ndimage import distance_transform_edt

    h, w = grid.shape
    ix0, iy0, ix1, iy1 = box if box is not None else (0, 0, w, h)
    m = int(np.ceil(4 * sigma / grid.params.resolution))
    x0, y0, x1, y1 = max(ix0 - m, 0), max(iy0 - m, 0), min(ix1 + m, w), min(iy1 + m, h)
    occupied = _probability(grid.log_odds[y0:y1, x0:x1]) > grid.params.cells.occupied_threshold
    if occupied.any():
        d = distance_transform_edt(~occupied) * grid.params.resolution
        G = np.log(p_floor + (1.0 - p_floor) * np.exp(-0.5 * (d / sigma) ** 2))
    else:
        G = np.full(occupied.shape, np.log(p_floor))
    return G[iy0 - y0 : iy1 - y0, ix0 - x0 : ix1 - x0]


@njit(cache=True)
def _node_score(P, ix, iy, a, b):
    h, w = P.shape
    total = 0.0
    for i in range(ix.shape[0]):
        x = min(max(ix[i] + a, 0), w - 1)
        y = min(max(iy[i] + b, 0), h - 1)
        total += P[y, x]
    return total


@njit(cache=True)
def _response(P, ix, iy, ks, a, b):
    """Scores S[q, j, i] of the points' cells ix, iy (K, N) at angle ks[q] shifted by (a[i], b[j])."""
    S = np.empty((ks.size, b.size, a.size))
    for q in range(ks.size):
        for j in range(b.size):
            for i in range(a.size):
                S[q, j, i] = _node_score(P, ix[ks[q]], iy[ks[q]], a[i], b[j])
    return S


@njit(cache=True)
def _branch_and_bound(pyramid, ix, iy, w, depth, floor):
    """Depth-first branch and bound (module docstring) over angles k and offsets |a|, |b| ≤ w.

    pyramid (depth + 1, H, W): P_0 … P_depth; ix, iy (K, N) the points' cells at each angle. Nodes are visited
    best-first (ties: larger k, a, b first, as a descending sort of (bound, k, a, b)); a node whose bound does
    not beat the best leaf so far — or ``floor``, a score not worth finding — is pruned. Returns (best score,
    k, a, b, nodes scored); the score is −inf when no candidate beats ``floor``."""
    K = ix.shape[0]
    step = 2**depth
    n_top = (2 * w) // step + 1
    M = K * n_top * n_top
    bound = np.empty(M)
    ks = np.empty(M, dtype=np.int64)
    As = np.empty(M, dtype=np.int64)
    Bs = np.empty(M, dtype=np.int64)
    m = 0
    for k in range(K):
        for j in range(n_top):
            for i in range(n_top):
                a = -w + i * step
                b = -w + j * step
                bound[m] = _node_score(pyramid[depth], ix[k], iy[k], a, b)
                ks[m], As[m], Bs[m] = k, a, b
                m += 1
    evaluated = M
    # best first: descending (bound, k, a, b)
    order = np.arange(M)
    keys = np.empty(M)
    for r in range(3, -1, -1):  # stable sorts from the least significant key: b, a, k, bound
        for q in range(M):
            idx = order[q]
            keys[q] = -(Bs[idx] if r == 3 else As[idx] if r == 2 else ks[idx] if r == 1 else bound[idx])
        order = order[np.argsort(keys, kind="mergesort")]
    cap = M + 4 * depth + 4
    st_h = np.empty(cap, dtype=np.int64)
    st_k = np.empty(cap, dtype=np.int64)
    st_a = np.empty(cap, dtype=np.int64)
    st_b = np.empty(cap, dtype=np.int64)
    st_s = np.empty(cap)
    sp = 0
    for q in range(M - 1, -1, -1):  # push worst first: the best is popped first
        idx = order[q]
        st_h[sp], st_k[sp], st_a[sp], st_b[sp], st_s[sp] = depth, ks[idx], As[idx], Bs[idx], bound[idx]
        sp += 1
    best, best_k, best_a, best_b = floor, 0, 0, 0
    found = False
    cs = np.empty(4)
    ca = np.empty(4, dtype=np.int64)
    cb = np.empty(4, dtype=np.int64)
    while sp > 0:
        sp -= 1
        h, k, a, b, sc = st_h[sp], st_k[sp], st_a[sp], st_b[sp], st_s[sp]
        if sc <= best:
            continue
        if h == 0:
            best, best_k, best_a, best_b = sc, k, a, b
            found = True
            continue
        half = 2 ** (h - 1)
        n = 0
        for da, db in ((0, 0), (half, 0), (0, half), (half, half)):
            if a + da <= w and b + db <= w:
                ca[n], cb[n] = a + da, b + db
                cs[n] = _node_score(pyramid[h - 1], ix[k], iy[k], a + da, b + db)
                n += 1
        evaluated += n
        # push the children worst first, so that they pop in descending (score, a, b)
        for _ in range(n):
            worst = 0
            for c in range(1, n):
                if cs[c] < cs[worst] or (
                    cs[c] == cs[worst] and (ca[c] < ca[worst] or (ca[c] == ca[worst] and cb[c] < cb[worst]))
                ):
                    worst = c
            st_h[sp], st_k[sp], st_a[sp], st_b[sp], st_s[sp] = h - 1, k, ca[worst], cb[worst], cs[worst]
            sp += 1
            cs[worst] = np.inf  # taken
            ca[worst] = np.iinfo(np.int64).max
            cb[worst] = np.iinfo(np.int64).max
    return (best if found else -np.inf), best_k, best_a, best_b, evaluated


class _Correlative:
    """The pieces the exhaustive and the branch-and-bound search share; ``Params`` is the subclass's model."""

    kind = "grid"
    takes_odometry = False

    def __init__(self, params: CorrelativeMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self._cache_key = None
        self._cache: dict = {}

    # ----------------------------------------------------------- shared pieces
    def _grids(self, maps, depth: int, guess, reach: float):
        """Padded likelihood grid of the map region within ``reach`` of the guess (snapped to
        blocks of 64 cells) and, for ``depth > 0``, its max-pyramid; cached per map version."""
        grid = maps.levels[min(self.params.level, len(maps.levels) - 1)]
        h, w = grid.shape
        lo = np.clip((grid.world_to_grid(np.asarray(guess[:2]) - reach) // _BLOCK) * _BLOCK, 0, [w, h])
        hi = np.clip((grid.world_to_grid(np.asarray(guess[:2]) + reach) // _BLOCK + 1) * _BLOCK, 0, [w, h])
        key = (id(grid), grid.version, grid.shape, depth, *lo, *hi)
        if key != self._cache_key:
            floor = np.log(self.params.p_floor)
            pad = 1  # a ring of floor cells: a lookup outside the array is clamped to its edge (exact for P_0, an upper bound for P_h)
            G = likelihood_grid(grid, self.params.sigma, self.params.p_floor, (lo[0], lo[1], hi[0], hi[1]))
            pyramid = np.empty(
                (depth + 1,) + tuple(np.add(G.shape, 2 * pad)), dtype=np.float32
            )  # P_0 … P_depth, one array
            pyramid[0] = np.pad(G, pad, constant_values=floor)
            for h in range(1, depth + 1):
                s = 2 ** (h - 1)
                P = pyramid[h]
                P[:] = pyramid[h - 1]
                np.maximum(P[:, :-s], P[:, s:], out=P[:, :-s])
                np.maximum(P[:-s, :], P[s:, :], out=P[:-s, :])
            self._cache_key = key
            self._cache = {"grid": grid, "pad": pad, "pyramid": pyramid, "corner": lo}
        return self._cache

    def _reach(self, grid, pts) -> float:
        r = float(np.max(np.hypot(pts[:, 0], pts[:, 1]))) if len(pts) else 0.0
        return r + self.params.linear_window + 4 * self.params.sigma + 2 * grid.params.resolution

    def _w(self, grid) -> int:
        return int(np.ceil(self.params.linear_window / grid.params.resolution - 1e-9))

    def _angles(self, grid, pts: np.ndarray) -> tuple[float, int]:
        r_max = max(float(np.max(np.hypot(pts[:, 0], pts[:, 1]))) if len(pts) else 1.0, grid.params.resolution)
        step = self.params.angular_step or float(np.arccos(1.0 - grid.params.resolution**2 / (2.0 * r_max**2)))
        return step, int(np.ceil(self.params.angular_window / step - 1e-9))

    @staticmethod
    def _cells(grid, pad, pts, guess, angles):
        """Cell indices (K, N) of the points at each rotation, translated by the guess, in the padded crop.

        ``pad`` is the padding minus the crop's lower-left corner ``(2,)``."""
        c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
        wx = guess[0] + c * pts[:, 0] - s * pts[:, 1]
        wy = guess[1] + s * pts[:, 0] + c * pts[:, 1]
        ix = np.floor((wx - grid.origin[0]) / grid.params.resolution).astype(np.int64) + pad[0]
        iy = np.floor((wy - grid.origin[1]) / grid.params.resolution).astype(np.int64) + pad[1]
        return ix, iy

    def _response(self, P, ix, iy, ks, w_a, w_b, centre=(0, 0)):
        """Exhaustive scores S[k, b, a] over angle indices ks and offsets centre ± (w_a, w_b)."""
        a = np.arange(centre[0] - w_a, centre[0] + w_a + 1)
        b = np.arange(centre[1] - w_b, centre[1] + w_b + 1)
        return (
            _response(
                P, np.ascontiguousarray(ix), np.ascontiguousarray(iy), np.asarray(list(ks), dtype=np.int64), a, b
            ),
            a,
            b,
        )

    @staticmethod
    def _moments(S, a, b, th, res, dth, guess):
        wts = np.exp(S - S.max())
        wts /= wts.sum()
        K, Bg, Ag = np.meshgrid(th, b * res, a * res, indexing="ij")
        xi = np.stack([Ag.ravel(), Bg.ravel(), K.ravel()], axis=1)
        mu = wts.ravel() @ xi
        d = xi - mu
        cov = (wts.ravel()[:, None] * d).T @ d + np.diag([res**2, res**2, dth**2]) / 12.0
        return cov

    def _result(self, maps, pts, grid, S_best, n, guess, a, b, th, cov, evaluated):
        pose = np.array([guess[0] + a * grid.params.resolution, guess[1] + b * grid.params.resolution, guess[2] + th])
        info = {"candidates_scored": int(evaluated)}
        if self.params.refine:
            from .gauss_newton import GaussNewtonMatcher

            info["lattice_pose"] = pose.copy()
            pose = GaussNewtonMatcher().match(maps, pts, pose).pose
        pose[2] = wrap_angle(pose[2])
        return MatchResult(pose=pose, cov=cov, score=float(S_best / max(n, 1)), iterations=int(evaluated), info=info)


class CorrelativeMatcherParams(Params):
    """Parameters of :class:`CorrelativeMatcher` (and of :class:`BranchAndBoundMatcher`, which adds one)."""

    linear_window: NonNegativeFloat = Field(
        0.3, description="half-width of the translation search around the guess [m] (w = ⌈linear_window / res⌉ cells)"
    )
    angular_window: NonNegativeFloat = Field(
        0.3, description="half-width of the rotation search around the guess [rad]"
    )
    angular_step: PositiveFloat | None = Field(
        None, description="rotation step δθ [rad]; None: arccos(1 − res² / 2 r_max²), the farthest point moves one cell"
    )
    sigma: PositiveFloat = Field(
        0.05, description="σ of the Gaussian smoothing of the obstacles in the likelihood grid [m]"
    )
    p_floor: float = Field(0.01, gt=0.0, lt=1.0, description="likelihood floor of a point that hits nothing mapped")
    level: NonNegativeInt = Field(
        0, description="pyramid level searched (0: finest; beyond the coarsest: the coarsest)"
    )
    refine: bool = Field(False, description="polish the lattice pose with the Gauss-Newton matcher on the pyramid")


class CorrelativeMatcher(_Correlative):
    """Exhaustive correlative scan matching over the search window (Olson 2009; :class:`CorrelativeMatcherParams`)."""

    Params = CorrelativeMatcherParams

    def match(self, maps, points, guess) -> MatchResult:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        guess = np.asarray(guess, dtype=float)
        grid = maps.levels[min(self.params.level, len(maps.levels) - 1)]
        w = self._w(grid)
        dth, na = self._angles(grid, pts)
        cache = self._grids(maps, 0, guess, self._reach(grid, pts))
        G, pad = cache["pyramid"][0], cache["pad"] - cache["corner"]
        offsets = np.arange(-na, na + 1) * dth
        ix, iy = self._cells(grid, pad, pts, guess, guess[2] + offsets)
        S, a, b = self._response(G, ix, iy, range(offsets.size), w, w)
        k, j, i = np.unravel_index(int(np.argmax(S)), S.shape)
        cov = self._moments(S, a, b, offsets, grid.params.resolution, dth, guess)
        return self._result(maps, pts, grid, S[k, j, i], len(pts), guess, a[i], b[j], offsets[k], cov, S.size)


class BranchAndBoundMatcherParams(CorrelativeMatcherParams):
    """Parameters of :class:`BranchAndBoundMatcher`: the correlative search's, the covariance window and the score floor."""

    covariance_cells: PositiveInt = Field(
        2,
        description="half-width of the exhaustive response around the optimum that gives the covariance [cells and angle steps]",
    )
    min_score: float | None = Field(
        None,
        le=0.0,
        description="mean log-likelihood per point below which a pose is not worth finding: the search prunes below it and "
        "reports no match (score −inf) when nothing beats it; None: the best pose, however poor",
    )


class BranchAndBoundMatcher(_Correlative):
    """Branch and bound over max-pyramids of the likelihood grid (Cartographer's fast matcher; :class:`BranchAndBoundMatcherParams`)."""

    Params = BranchAndBoundMatcherParams

    def match(self, maps, points, guess) -> MatchResult:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        guess = np.asarray(guess, dtype=float)
        grid0 = maps.levels[min(self.params.level, len(maps.levels) - 1)]
        w = self._w(grid0)
        depth = int(np.ceil(np.log2(2 * w + 1))) if w > 0 else 0
        grid = grid0
        dth, na = self._angles(grid, pts)
        cache = self._grids(maps, depth, guess, self._reach(grid, pts))
        pyramid, pad = cache["pyramid"], cache["pad"] - cache["corner"]
        offsets = np.arange(-na, na + 1) * dth
        ix, iy = self._cells(grid, pad, pts, guess, guess[2] + offsets)

        floor = -np.inf if self.params.min_score is None else self.params.min_score * len(pts)
        S_best, k, a, b, evaluated = _branch_and_bound(
            pyramid, np.ascontiguousarray(ix), np.ascontiguousarray(iy), w, depth, floor
        )
        if not np.isfinite(S_best):
            return MatchResult(
                pose=guess.copy(),
                cov=np.full((3, 3), np.inf),
                score=-np.inf,
                iterations=int(evaluated),
                info={"candidates_scored": int(evaluated), "below_min_score": True},
            )
        c = self.params.covariance_cells
        ks = range(max(k - c, 0), min(k + c, offsets.size - 1) + 1)
        S, ga, gb = self._response(pyramid[0], ix, iy, ks, c, c, centre=(a, b))
        cov = self._moments(S, ga, gb, offsets[list(ks)], grid.params.resolution, dth, guess)
        return self._result(maps, pts, grid, S_best, len(pts), guess, a, b, offsets[k], cov, evaluated)
