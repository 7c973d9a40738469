"""Point-to-line ICP of one 2D scan onto another (Censi 2008's error metric, solved by Gauss-Newton).

Reference: world points q_j (M, 2), each with the unit normal n_j of its neighbourhood: the eigenvector of the
smallest eigenvalue of the 2 × 2 covariance of the reference points within ``normal_radius`` of q_j (closed form:
the major axis of [[a, b], [b, c]] has angle φ = ½ atan2(2b, a − c), n_j = (−sin φ, cos φ)); a point with fewer
than 3 such neighbours has no line and is never paired. Scan: end points s_i (N, 2) in the robot frame. Pose
ξ = (t_x, t_y, ψ); S_i(ξ) = R(ψ) s_i + t. Each iteration pairs S_i with its nearest reference point j(i) when it
lies within ``max_correspondence`` and minimises, with the pairs fixed,

    E(ξ) = Σ_i r_i²,   r_i = n_{j(i)}ᵀ (S_i(ξ) − q_{j(i)})                       (scalar per pair)

by one Gauss-Newton step (the point-to-line residual is the distance to the reference's local line, so a scan
sliding along a wall costs nothing: that direction is left to the other walls):

    J_i = n_{j(i)}ᵀ [I₂, R'(ψ) s_i]   (1, 3),   R'(ψ) s = (−sinψ s_x − cosψ s_y, cosψ s_x − sinψ s_y)
    Δξ = −(Σ J_iᵀ J_i)⁻¹ Σ J_iᵀ r_i

until the step is below (``tol_translation``, ``tol_rotation``) or after ``max_iterations`` (a direction H does not
constrain is left at the guess). Covariance at the
result: the Laplace approximation σ̂² (Σ J_iᵀ J_i)⁻¹, σ̂² = Σ r_i² / (n − 3) (a corridor, whose walls all share one
normal, leaves the direction along it with a large variance). Score: the fraction of scan points paired.

Nearest neighbours: the reference points are binned into square cells of side max(``max_correspondence``,
``normal_radius``), so every point within that distance lies in the 3 × 3 cells around a query. Building a
reference (:meth:`PointToLineICPMatcher.prepare`, once per scan when a scan is matched against several) and the
iterations are numba kernels (the loops over points are inherent).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt

from slamarena.datasets.geometry import wrap_angle
from slamarena.params import Field, Params

from . import MatchResult
from .gauss_newton import accumulate_row

__all__ = ["PointToLineICPMatcher", "PointToLineICPMatcherParams", "PreparedReference", "residuals_and_jacobian"]


class PointToLineICPMatcherParams(Params):
    """Parameters of :class:`PointToLineICPMatcher`."""

    max_correspondence: PositiveFloat = Field(
        0.15, description="a scan point is paired with its nearest reference point only within this distance [m]"
    )
    normal_radius: PositiveFloat = Field(
        0.25, description="a reference point's line is fitted to the reference points within this distance [m]"
    )
    max_iterations: PositiveInt = Field(30, description="most ICP iterations (each: new pairs, one Gauss-Newton step)")
    tol_translation: NonNegativeFloat = Field(
        1e-5, description="ICP stops when a step moves less than this [m] (and turns less than tol_rotation)"
    )
    tol_rotation: NonNegativeFloat = Field(
        1e-5, description="ICP stops when a step turns less than this [rad] (and moves less than tol_translation)"
    )


@dataclass
class PreparedReference:
    """A reference point set (M, 2) binned into cells: points and unit normals sorted by cell (NaN normal: no
    line), ``start`` (ny · nx + 1,) the first sorted point of each cell, the grid's origin (2,) and cell side."""

    points: np.ndarray
    normals: np.ndarray
    start: np.ndarray
    origin: np.ndarray
    cell: float
    shape: tuple[int, int]


def residuals_and_jacobian(
    pose: np.ndarray, points: np.ndarray, q: np.ndarray, n: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """r_i = n_iᵀ(R(ψ) s_i + t − q_i) (N,) and its Jacobian J (N, 3) with respect to ξ = (t_x, t_y, ψ) (module
    docstring; the literal form of what the numba kernel accumulates)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    x, y = points[:, 0], points[:, 1]
    wx, wy = c * x - s * y + pose[0], s * x + c * y + pose[1]
    r = n[:, 0] * (wx - q[:, 0]) + n[:, 1] * (wy - q[:, 1])
    J = np.column_stack([n[:, 0], n[:, 1], n[:, 0] * (-s * x - c * y) + n[:, 1] * (c * x - s * y)])
    return r, J


@njit(cache=True)
def _bin(points, origin, cell, nx, ny):
    """Sort the points by cell: (order, start) with start[c] … start[c + 1] the sorted indices of cell c."""
    idx = np.empty(points.shape[0], np.int64)
    for i in range(points.shape[0]):
        cx = min(max(int((points[i, 0] - origin[0]) / cell), 0), nx - 1)
        cy = min(max(int((points[i, 1] - origin[1]) / cell), 0), ny - 1)
        idx[i] = cy * nx + cx
    order = np.argsort(idx, kind="mergesort")
    start = np.zeros(nx * ny + 1, np.int64)
    for i in range(points.shape[0]):
        start[idx[i] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    return order, start


@njit(cache=True)
def _nearest(P, start, origin, cell, nx, ny, wx, wy, gate, need_line, N):
    """Index of the nearest sorted reference point within ``gate`` of (wx, wy) (with a line when ``need_line``), or −1."""
    cx = int(np.floor((wx - origin[0]) / cell))
    cy = int(np.floor((wy - origin[1]) / cell))
    best = -1
    bd = gate * gate
    for yy in range(max(cy - 1, 0), min(cy + 2, ny)):
        for xx in range(max(cx - 1, 0), min(cx + 2, nx)):
            c = yy * nx + xx
            for j in range(start[c], start[c + 1]):
                if need_line and np.isnan(N[j, 0]):
                    continue
                d = (P[j, 0] - wx) ** 2 + (P[j, 1] - wy) ** 2
                if d <= bd:
                    bd = d
                    best = j
    return best


@njit(cache=True)
def _normals(P, start, origin, cell, nx, ny, radius):
    """Unit normals (M, 2) of the sorted points from their neighbours within ``radius`` (NaN: fewer than 3)."""
    M = P.shape[0]
    N = np.full((M, 2), np.nan)
    r2 = radius * radius
    for i in range(M):
        cx = int(np.floor((P[i, 0] - origin[0]) / cell))
        cy = int(np.floor((P[i, 1] - origin[1]) / cell))
        n = 0
        sx = sy = sxx = sxy = syy = 0.0
        for yy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for xx in range(max(cx - 1, 0), min(cx + 2, nx)):
                c = yy * nx + xx
                for j in range(start[c], start[c + 1]):
                    dx = P[j, 0] - P[i, 0]
                    dy = P[j, 1] - P[i, 1]
                    if dx * dx + dy * dy <= r2:
                        n += 1
                        sx += dx
                        sy += dy
                        sxx += dx * dx
                        sxy += dx * dy
                        syy += dy * dy
        if n >= 3:
            a = sxx / n - (sx / n) ** 2
            b = sxy / n - (sx / n) * (sy / n)
            d = syy / n - (sy / n) ** 2
            phi = 0.5 * np.arctan2(2.0 * b, a - d)
            N[i, 0] = -np.sin(phi)
            N[i, 1] = np.cos(phi)
    return N


@njit(cache=True)
def _normal_equations(P, N, start, origin, cell, nx, ny, pts, pose, gate):
    """H = Σ JᵀJ (3, 3), g = Σ Jᵀr (3,), Σ r² and the number of paired scan points at ``pose``."""
    c = np.cos(pose[2])
    s = np.sin(pose[2])
    H = np.zeros((3, 3))
    g = np.zeros(3)
    ssr = 0.0
    n = 0
    for i in range(pts.shape[0]):
        x = pts[i, 0]
        y = pts[i, 1]
        wx = c * x - s * y + pose[0]
        wy = s * x + c * y + pose[1]
        j = _nearest(P, start, origin, cell, nx, ny, wx, wy, gate, True, N)
        if j < 0:
            continue
        r = N[j, 0] * (wx - P[j, 0]) + N[j, 1] * (wy - P[j, 1])
        accumulate_row(H, g, N[j, 0], N[j, 1], N[j, 0] * (-s * x - c * y) + N[j, 1] * (c * x - s * y), r)
        ssr += r * r
        n += 1
    H[1, 0] = H[0, 1]
    H[2, 0] = H[0, 2]
    H[2, 1] = H[1, 2]
    return H, g, ssr, n


@njit(cache=True)
def _icp(P, N, start, origin, cell, nx, ny, pts, guess, gate, iterations, tol_t, tol_r):
    """The iterations of the module docstring: (pose, H, Σ r², paired, iterations) at the result; fewer than 3 pairs
    stop early. A direction the pairs do not constrain (eigenvalue of H below 10⁻⁹ of the largest: a featureless
    corridor) is left where the guess put it (the step is solved in the eigenvectors of H that are kept)."""
    pose = guess.copy()
    it = 0
    for it in range(1, iterations + 1):
        H, g, ssr, n = _normal_equations(P, N, start, origin, cell, nx, ny, pts, pose, gate)
        if n < 3:
            return pose, H, ssr, n, it
        w, V = np.linalg.eigh(H)
        keep = w > 1e-9 * w[-1]
        if not keep[-1]:
            return pose, H, ssr, n, it
        step = -(V[:, keep] @ ((V[:, keep].T @ g) / w[keep]))
        pose += step
        if np.hypot(step[0], step[1]) < tol_t and abs(step[2]) < tol_r:
            break
    H, g, ssr, n = _normal_equations(P, N, start, origin, cell, nx, ny, pts, pose, gate)
    return pose, H, ssr, n, it


class PointToLineICPMatcher:
    """Point-to-line ICP (module docstring, :class:`PointToLineICPMatcherParams`)."""

    kind = "points"
    takes_odometry = False
    Params = PointToLineICPMatcherParams

    def __init__(self, params: PointToLineICPMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def prepare(self, reference: np.ndarray) -> PreparedReference:
        """The reference binned into cells, with its normals, for matching several scans against it."""
        p = self.params
        reference = np.ascontiguousarray(reference, dtype=np.float64).reshape(-1, 2)
        cell = max(p.max_correspondence, p.normal_radius)
        lo = reference.min(axis=0) - cell if len(reference) else np.zeros(2)
        hi = reference.max(axis=0) + cell if len(reference) else np.zeros(2)
        nx, ny = (int(v) + 1 for v in np.ceil((hi - lo) / cell))
        order, start = _bin(reference, lo, cell, nx, ny)
        points = np.ascontiguousarray(reference[order])
        return PreparedReference(
            points, _normals(points, start, lo, cell, nx, ny, p.normal_radius), start, lo, cell, (ny, nx)
        )

    def match(self, reference, points, guess) -> MatchResult:
        """Scan ``points`` (N, 2, robot frame) onto ``reference`` (world points (M, 2) or a :class:`PreparedReference`) from ``guess``."""
        p = self.params
        ref = reference if isinstance(reference, PreparedReference) else self.prepare(reference)
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        ny, nx = ref.shape
        pose, H, ssr, n, it = _icp(
            ref.points,
            ref.normals,
            ref.start,
            ref.origin,
            ref.cell,
            nx,
            ny,
            pts,
            np.asarray(guess, dtype=np.float64),
            p.max_correspondence,
            p.max_iterations,
            p.tol_translation,
            p.tol_rotation,
        )
        pose[2] = wrap_angle(pose[2])
        eig = np.linalg.eigvalsh(H) if n > 3 else np.zeros(3)
        cov = ssr / (n - 3) * np.linalg.inv(H) if eig[0] * 1e12 >= eig[-1] > 0 else np.diag([np.inf] * 3)
        return MatchResult(pose=pose, cov=cov, score=n / max(len(pts), 1), iterations=it, info={"paired": n})
