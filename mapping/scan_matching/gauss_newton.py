"""Gauss-Newton scan-to-map matching on a bilinearly interpolated occupancy map (Hector SLAM).

Objective (Kohlbrecher et al. 2011, eq. 6): with scan end points s_i (robot frame),
pose ξ = (p_x, p_y, ψ) and the transformed points

    S_i(ξ) = R(ψ) s_i + (p_x, p_y)ᵀ                                         (2,)

find  ξ* = argmin_ξ  Σ_i [1 − M(S_i(ξ))]²,  M ∈ [0, 1] the interpolated occupancy
probability: scan points should land on occupied cells (the technical notes' Σ M(S_i)² has
the sign of the residual wrong — minimising it pushes the scan into free space).

Linearising M(S_i(ξ + Δξ)) ≈ M(S_i(ξ)) + J_i Δξ with the 1 × 3 row

    J_i = ∇M(S_i) · ∂S_i/∂ξ,   ∂S_i/∂ξ = [[1, 0, −sinψ s_x − cosψ s_y],
                                         [0, 1,  cosψ s_x − sinψ s_y]]       (2, 3)

gives the Gauss-Newton step (eq. 12)

    H = Σ J_iᵀ J_i  (3, 3),     Δξ = H⁻¹ Σ J_iᵀ [1 − M(S_i(ξ))]   (3,)

Bilinear interpolation on the cell-centre lattice (integer grid coordinates at cell
centres; f_x, f_y the fractions within the 2 × 2 neighbourhood m00, m10, m01, m11):

    M      = (1−f_y)[(1−f_x) m00 + f_x m10] + f_y[(1−f_x) m01 + f_x m11]
    ∂M/∂x  = [(1−f_y)(m10 − m00) + f_y (m11 − m01)] / res
    ∂M/∂y  = [(1−f_x)(m01 − m00) + f_x (m11 − m10)] / res

Hector's published code (GridMapUtil::interpMapValueWithDerivatives) weights the x
differences with the x fractions and the y differences with the y fractions,
``(1−f_x)(m10 − m00) + f_x (m11 − m01)`` and ``(1−f_y)(m01 − m00) + f_y (m11 − m10)``; the flag
``hector_gradient_bug=True`` reproduces it (research/method/grid_mapping.md shows the difference).

Multi-resolution: the match runs on each level of a :class:`~slamarena.mapping.map_pyramid.MapPyramid`
from coarse to fine, each level starting from the previous result. Each level iterates
at most ``iterations`` times, stops when a step is below ``(tol_translation, tol_rotation)``,
and clamps every step to ``(max_step_translation · level resolution / finest resolution,
max_step_rotation)``. The covariance is the Gauss-Newton (Laplace) approximation on the
finest level, ``Σ = σ̂² H⁻¹`` with ``σ̂² = Σ r_i² / (n − 3)``. Score: the mean of M over the
scan points on the finest level (0 … 1).

The per-level solver is one numba kernel (the loop over points is inherent).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt

from slamarena.params import Field, Params

from . import MatchResult

__all__ = ["GaussNewtonMatcher", "GaussNewtonMatcherParams", "interpolate", "solve_level"]


@njit(cache=True)
def _p(l):
    return 1.0 / (1.0 + np.exp(-l))


@njit(cache=True)
def _interp(L, ox, oy, res, wx, wy, bug):
    """(M, ∂M/∂x, ∂M/∂y) at world point (wx, wy); zero outside the grid (as Hector)."""
    h, w = L.shape
    gx = (wx - ox) / res - 0.5
    gy = (wy - oy) / res - 0.5
    x0 = int(np.floor(gx))
    y0 = int(np.floor(gy))
    if x0 < 0 or y0 < 0 or x0 + 1 >= w or y0 + 1 >= h:
        return 0.0, 0.0, 0.0, False
    fx = gx - x0
    fy = gy - y0
    M, dx, dy = bilinear(L[y0, x0], L[y0, x0 + 1], L[y0 + 1, x0], L[y0 + 1, x0 + 1], fx, fy, res, bug)
    return M, dx, dy, True


@njit(cache=True, inline="always")
def bilinear(l00, l10, l01, l11, fx, fy, res, bug):
    """(M, ∂M/∂x, ∂M/∂y) from the log-odds of the 2 × 2 cells around a point at fractions (fx, fy) (module docstring)."""
    m00 = _p(l00)
    m10 = _p(l10)
    m01 = _p(l01)
    m11 = _p(l11)
    M = (1.0 - fy) * ((1.0 - fx) * m00 + fx * m10) + fy * ((1.0 - fx) * m01 + fx * m11)
    if bug:
        dx = (1.0 - fx) * (m10 - m00) + fx * (m11 - m01)
        dy = (1.0 - fy) * (m01 - m00) + fy * (m11 - m10)
    else:
        dx = (1.0 - fy) * (m10 - m00) + fy * (m11 - m01)
        dy = (1.0 - fx) * (m01 - m00) + fx * (m11 - m10)
    return M, dx / res, dy / res


@njit(cache=True)
def interpolate(L, ox, oy, res, xy, bug=False):
    """Vectorised :func:`_interp` over world points ``xy`` (N, 2) → (N, 3) [M, ∂M/∂x, ∂M/∂y]."""
    out = np.zeros((xy.shape[0], 3))
    for i in range(xy.shape[0]):
        M, dx, dy, _ = _interp(L, ox, oy, res, xy[i, 0], xy[i, 1], bug)
        out[i, 0] = M
        out[i, 1] = dx
        out[i, 2] = dy
    return out


@njit(cache=True)
def _normal_equations(L, ox, oy, res, pts, x, y, th, bug):
    c = np.cos(th)
    s = np.sin(th)
    H = np.zeros((3, 3))
    g = np.zeros(3)
    ssr = 0.0
    msum = 0.0
    n = 0
    for i in range(pts.shape[0]):
        sx = pts[i, 0]
        sy = pts[i, 1]
        M, dMx, dMy, inside = _interp(L, ox, oy, res, x + c * sx - s * sy, y + s * sx + c * sy, bug)
        if not inside:
            continue
        ssr += accumulate_point(H, g, M, dMx, dMy, sx, sy, c, s)
        msum += M
        n += 1
    H[1, 0] = H[0, 1]
    H[2, 0] = H[0, 2]
    H[2, 1] = H[1, 2]
    return H, g, ssr, msum, n


@njit(cache=True, inline="always")
def accumulate_point(H, g, M, dMx, dMy, sx, sy, c, s):
    """Add one end point s = (sx, sy) with map value M and gradient ∇M at S(ξ) (c, s = cos ψ, sin ψ) to the upper
    triangle of H = Σ JᵀJ and to g = Σ Jᵀr; returns r² (r = 1 − M, J = ∇M ∂S/∂ξ)."""
    r = 1.0 - M
    accumulate_row(H, g, dMx, dMy, dMx * (-s * sx - c * sy) + dMy * (c * sx - s * sy), r)
    return r * r


@njit(cache=True, inline="always")
def accumulate_row(H, g, J0, J1, J2, r):
    """Add one residual r with its 1 × 3 Jacobian row (J0, J1, J2) to the upper triangle of H = Σ JᵀJ and to g = Σ Jᵀr."""
    H[0, 0] += J0 * J0
    H[0, 1] += J0 * J1
    H[0, 2] += J0 * J2
    H[1, 1] += J1 * J1
    H[1, 2] += J1 * J2
    H[2, 2] += J2 * J2
    g[0] += J0 * r
    g[1] += J1 * r
    g[2] += J2 * r


@njit(cache=True)
def _solve3(H, g):
    """H⁻¹ g for a symmetric 3 × 3 H by cofactors; ok=False when H is (near) singular."""
    c00 = H[1, 1] * H[2, 2] - H[1, 2] * H[2, 1]
    c01 = H[1, 2] * H[2, 0] - H[1, 0] * H[2, 2]
    c02 = H[1, 0] * H[2, 1] - H[1, 1] * H[2, 0]
    det = H[0, 0] * c00 + H[0, 1] * c01 + H[0, 2] * c02
    scale = H[0, 0] * H[1, 1] * H[2, 2]
    d = np.zeros(3)
    if not scale > 0.0 or abs(det) <= 1e-12 * scale:
        return d, False
    c11 = H[0, 0] * H[2, 2] - H[0, 2] * H[2, 0]
    c12 = H[0, 1] * H[2, 0] - H[0, 0] * H[2, 1]
    c22 = H[0, 0] * H[1, 1] - H[0, 1] * H[1, 0]
    d[0] = (c00 * g[0] + c01 * g[1] + c02 * g[2]) / det
    d[1] = (c01 * g[0] + c11 * g[1] + c12 * g[2]) / det
    d[2] = (c02 * g[0] + c12 * g[1] + c22 * g[2]) / det
    return d, True


@njit(cache=True, inline="always")
def take_step(d, x, y, th, max_step_t, max_step_r, tol_t, tol_r):
    """The pose moved by the step d (3,) clamped to (max_step_t, max_step_r), and whether the step was below
    (tol_t, tol_r) (converged)."""
    t = np.hypot(d[0], d[1])
    if t > max_step_t:
        d[0] *= max_step_t / t
        d[1] *= max_step_t / t
    if abs(d[2]) > max_step_r:
        d[2] = max_step_r * np.sign(d[2])
    return x + d[0], y + d[1], th + d[2], np.hypot(d[0], d[1]) < tol_t and abs(d[2]) < tol_r


@njit(cache=True)
def solve_level(L, ox, oy, res, pts, pose, iterations, tol_t, tol_r, max_step_t, max_step_r, bug, prior, w_t, w_r):
    """Gauss-Newton on one grid from ``pose``; returns (pose, H, ssr, Σ M, n, iterations).

    ``w_t, w_r > 0`` add the prior term ``w_t‖t − t̂‖² + w_r(ψ − ψ̂)²`` towards ``prior``.
    """
    x, y, th = pose[0], pose[1], pose[2]
    it = 0
    for it in range(1, iterations + 1):
        H, g, ssr, msum, n = _normal_equations(L, ox, oy, res, pts, x, y, th, bug)
        if n < 3:
            break
        H[0, 0] += w_t
        H[1, 1] += w_t
        H[2, 2] += w_r
        g[0] += w_t * (prior[0] - x)
        g[1] += w_t * (prior[1] - y)
        g[2] += w_r * (prior[2] - th)
        d, ok = _solve3(H, g)
        if not ok:
            break
        x, y, th, converged = take_step(d, x, y, th, max_step_t, max_step_r, tol_t, tol_r)
        if converged:
            break
    H, g, ssr, msum, n = _normal_equations(L, ox, oy, res, pts, x, y, th, bug)
    return np.array([x, y, th]), H, ssr, msum, n, it


class GaussNewtonMatcherParams(Params):
    """Parameters of :class:`GaussNewtonMatcher`.

    The prior weights add ``w_t‖t − t̂‖² + w_r(ψ − ψ̂)²`` towards the guess ξ̂ to the objective, as
    Cartographer's Ceres matcher does: directions the map does not constrain (along a corridor) then follow
    the guess instead of drifting on the coarse levels (on sim:laser, pure Hector jumps 0.2–0.3 m along the
    first corridor; research/method/grid_mapping.md). Default 100 each, small against the map's H (10⁴–10⁵ per m² in
    constrained directions); 0 gives Hector's objective exactly.
    """

    iterations: PositiveInt = Field(10, description="most Gauss-Newton iterations per pyramid level")
    tol_translation: NonNegativeFloat = Field(
        1e-4, description="a level stops when a step moves less than this [m] (and turns less than tol_rotation)"
    )
    tol_rotation: NonNegativeFloat = Field(
        1e-4, description="a level stops when a step turns less than this [rad] (and moves less than tol_translation)"
    )
    max_step_translation: PositiveFloat = Field(
        0.1, description="step clamp on the finest level [m], scaled with each level's resolution"
    )
    max_step_rotation: PositiveFloat = Field(0.2, description="step clamp [rad]")
    hector_gradient_bug: bool = Field(
        False, description="reproduce the gradient weights of Hector's published code (module docstring)"
    )
    prior_translation_weight: NonNegativeFloat = Field(
        100.0, description="w_t of the prior towards the guess [1/m²]; 0: Hector's objective"
    )
    prior_rotation_weight: NonNegativeFloat = Field(
        100.0, description="w_r of the prior towards the guess [1/rad²]; 0: Hector's objective"
    )


class GaussNewtonMatcher:
    """Hector-style multi-resolution Gauss-Newton scan-to-map matcher (module docstring, :class:`GaussNewtonMatcherParams`)."""

    kind = "grid"
    Params = GaussNewtonMatcherParams

    def __init__(self, params: GaussNewtonMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def match(self, maps, points: np.ndarray, guess: np.ndarray) -> MatchResult:
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        guess = np.asarray(guess, dtype=np.float64)
        pose = guess.copy()
        p = self.params
        fine = maps.levels[0].params.resolution
        total = 0
        for grid in reversed(maps.levels):
            res = grid.params.resolution
            pose, H, ssr, msum, n, it = solve_level(
                grid.log_odds,
                grid.origin[0],
                grid.origin[1],
                res,
                pts,
                pose,
                p.iterations,
                p.tol_translation,
                p.tol_rotation,
                p.max_step_translation * res / fine,
                p.max_step_rotation,
                p.hector_gradient_bug,
                guess,
                p.prior_translation_weight,
                p.prior_rotation_weight,
            )
            total += it
        # not wrap_angle: changing the last bit of this heading (wrap_angle rounds differently from this formula) moves
        # LaserSLAM's mean relation error on MIT-CSAIL from 0.031 m to 1.30 m (tests/mapping/test_laser_slam.py::
        # test_relations_on_mit_csail; research/notebook/2026-11-28-refactor.md) — a knife edge to understand first
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        cov = _laplace_covariance(H, ssr, n)
        return MatchResult(
            pose=pose, cov=cov, score=msum / n if n else 0.0, iterations=total, info={"points_on_map": n}
        )


def _laplace_covariance(H: np.ndarray, ssr: float, n: int) -> np.ndarray:
    eig = (
        np.linalg.eigvalsh(H) if n > 3 else np.zeros(3)
    )  # ascending; H is symmetric: its condition number is eig[-1] / eig[0]
    if not eig[0] * 1e12 >= eig[-1] > 0:
        return np.diag([np.inf, np.inf, np.inf])
    return ssr / (n - 3) * np.linalg.inv(H)
