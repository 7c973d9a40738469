"""Gauss-Newton scan-to-map matching on an interpolated occupancy map (Hector SLAM).

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

Interpolation on the cell-centre lattice (integer grid coordinates at cell centres; f_x, f_y the fractions of the
point within its cell; m_ij = 1/(1 + exp(−l_ij)) the cells' occupancy probabilities). Bicubic, the default (as
Cartographer's Ceres matcher, Ceres' BiCubicInterpolator): the Catmull-Rom spline through the 4 × 4 cells
m_ij, i, j ∈ {−1, 0, 1, 2}, along x in each row and then along y,

    C(p_{−1}, p_0, p_1, p_2; f) = p_0 + f (c + f (b + f a)),   c = (p_1 − p_{−1})/2,
    b = p_{−1} − 5p_0/2 + 2p_1 − p_2/2,   a = (−p_{−1} + 3p_0 − 3p_1 + p_2)/2
    M = C(r_{−1}, …, r_2; f_y),  r_j = C(m_{−1j}, …, m_{2j}; f_x);   ∂M/∂x = C(∂r_j/∂f_x; f_y)/res,  ∂M/∂y = C'(r_j; f_y)/res

M passes through the cell values and is C¹: value and gradient are continuous where the patches meet, on the lines
through the cell centres. Bilinear (``interpolation="bilinear"``, Hector's; the 2 × 2 neighbourhood m00 … m11):

    M      = (1−f_y)[(1−f_x) m00 + f_x m10] + f_y[(1−f_x) m01 + f_x m11]
    ∂M/∂x  = [(1−f_y)(m10 − m00) + f_y (m11 − m01)] / res
    ∂M/∂y  = [(1−f_x)(m01 − m00) + f_x (m11 − m10)] / res

is only C⁰: ∇M jumps on every line through the cell centres. Hector's published code
(GridMapUtil::interpMapValueWithDerivatives) weights the x differences with the x fractions and the y differences with the y fractions,
``(1−f_x)(m10 − m00) + f_x (m11 − m01)`` and ``(1−f_y)(m01 − m00) + f_y (m11 − m10)``; the flag
``hector_gradient_bug=True`` (bilinear only) reproduces it (research/method/grid_mapping.md shows the difference).

Multi-resolution: the match runs on each level of a :class:`~slamarena.mapping.map_pyramid.MapPyramid`
from coarse to fine, each level starting from the previous result, with at most ``iterations`` Gauss-Newton
directions per level, each clamped to ``(max_step_translation · level resolution / finest resolution,
max_step_rotation)``.

Iteration. By default Hector's: every step is the full (clamped) Gauss-Newton step d. JᵀJ leaves out Σ r_i ∇²r_i,
which is positive where points sit on the concave shoulder of a wall's peak, so the full step overshoots the minimum
along d (by 1.5–1.9× on MIT-CSAIL); by more than 2× it does not converge and alternates between two poses
centimetres apart up to the cap (a two-cycle), the result then the cycle's phase. With ``line_search`` the step is
α d with a line search on the actual F: with F(ξ + αd) ≈ F(ξ) + F'α + κα², F' = −bᵀd < 0, κ from the trial
F(ξ + αd), starting at α = 1,

    F(ξ + αd) < F(ξ):  take it, or α* = −F'/(2κ) ∈ [α/10, 0.9 α) if F is lower there still (the parabola's minimum);
    otherwise:         retry at α ← clamp(α*, α/10, α/2), and stop the level below α = 10⁻³.

A level stops after a step below ``(tol_translation, tol_rotation)``. The line search on the C¹ bicubic map is a
descent whose result is a smooth function of the guess: a last-bit change of the guess (another angle wrap) moves it
by 10⁻¹¹ m on MIT-CSAIL, where on the bilinear map's kinks any iteration's decisions turn it into metres. It is not the
default: a converged match carries the frontier pull below in full, and laser graph SLAM's simulated rows moved the
wrong way (research/method/laser_degeneracy.md, "The branch cut"). Score: the mean of M over the scan points on the
finest level (0 … 1).

Unobserved cells (``skip_unobserved``). A cell nothing has observed holds the prior l0 (M = p0 = ½). End points past
the map's frontier (the far end of a scan that the map has not caught up with: a submap, or a map the motion filter
fills every 0.4 m) fall on such cells beside the mapped walls and pull the scan back to where the walls are mapped,
a bias backwards along the track. With the option the end points whose finest-level cell at the guess is unobserved
are left out of the match (every level; the set is fixed for the match, so F stays one function); the score is
still the mean over every end point.

A poor match (``search_below_score`` s_min > 0). A guess on the wrong side of a ridge of F (MIT-CSAIL scan 1156: the
odometry turns 0.70 rad in 0.21 s) ends in a local minimum whose score is that of end points on unobserved cells or
below. When the score is below s_min, an exhaustive correlative search (:mod:`.correlative`, ``search_window``, by
default Cartographer's real-time correlative matcher's 0.1 m and 20°) around the guess gives a second start, its
best lattice pose, which is also the second match's prior; the higher-scoring of the two matches is the result
(as Cartographer's online correlative scan matching seeds its Ceres matcher, here only after a poor match), its
``info["searched"]`` 1 and ``info["from_search"]`` whether it is the second.

Prior and covariance. The objective has ``½ eᵀWe``, ``e = ξ̂ − ξ`` towards the guess, W = diag(w_t, w_t, w_r)
(``prior_*_weight``, as Cartographer's Ceres matcher); in information form Σ r_i²/σ̂² + eᵀΛe with the odometry's
information Λ = W/σ̂². The covariance is the Laplace approximation ``Σ = σ̂² H⁻¹`` on the finest level,
``σ̂² = Σ r_i² / (n − 3)``.

Degeneracy (``match(…, odometry=True)``: the guess carries the odometry's motion; ``degeneracy_threshold`` τ > 0;
research/method/laser_degeneracy.md). Where the scan's far end reaches past the mapped walls, unobserved cells
(M = ½) beside the mapped ones pull the scan back along a corridor, every scan, so H cannot say which directions the
scan constrains; the scan's own geometry does. With the unit normal n_i of the line through each end point's
neighbours (the point-to-line ICP's normals),

    I_s = Σ_i J_iᵀ J_i,   J_i = n_iᵀ [I₂, R'(ψ) s_i]   (1, 3)                                      (3, 3)

and λ_0 ≤ λ_1, u_0, u_1 the eigenvalues and unit eigenvectors of its translation block (2, 2), u_0 is degenerate
when λ_0 < τ λ_1 (Zhang, Kaess & Singh 2016). With T = blockdiag([u_0 u_1], 1) the pose then moves only in the kept
directions, ξ = ξ₀ + T c with c_0 = 0, each step solving (TᵀAT) c = Tᵀb over (c_1, c_2) (A = H + W, b = g + We):
along u_0 it keeps the odometry's guess. The covariance handed on is the posterior of the fused objective with the
scan's information kept where the scan has it,

    Σ = T (K Tᵀ (H/σ̂²) T K + Tᵀ Λ T)⁻¹ Tᵀ,   K = diag(0, 1, 1)                                      (3, 3)

(σ̂² and H at the match): along u_0 the odometry's variance σ̂²/w_t, elsewhere the scan's and the odometry's
information summed. ``info["degenerate"]`` is 1 for such a match. ``info["information"]`` (every match) is the
scan's information without the prior, H/σ̂² projected onto the kept directions (:func:`match_information`).

The per-level solver is one numba kernel (the loop over points is inherent).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numba import njit
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt, model_validator

from slamarena.datasets.geometry import transform_points
from slamarena.params import Field, Params

from . import MatchResult
from .correlative import CorrelativeMatcher

__all__ = [
    "Fusion",
    "GaussNewtonMatcher",
    "GaussNewtonMatcherParams",
    "degenerate_basis",
    "interpolate",
    "observed",
    "solve_level",
]


@njit(cache=True)
def _p(l):
    return 1.0 / (1.0 + np.exp(-l))


@njit(cache=True)
def _interp(L, ox, oy, res, wx, wy, kind):
    """(M, ∂M/∂x, ∂M/∂y, inside) at world point (wx, wy): ``kind`` 0 bilinear, 1 bilinear with Hector's gradient weights,
    2 bicubic (module docstring); zero and not inside where the 2 × 2 (4 × 4) neighbourhood leaves the grid (as Hector)."""
    h, w = L.shape
    gx = (wx - ox) / res - 0.5
    gy = (wy - oy) / res - 0.5
    x0 = int(np.floor(gx))
    y0 = int(np.floor(gy))
    fx = gx - x0
    fy = gy - y0
    if kind == BICUBIC:
        if x0 < 1 or y0 < 1 or x0 + 2 >= w or y0 + 2 >= h:
            return 0.0, 0.0, 0.0, False
        M, dx, dy = bicubic(L, x0, y0, fx, fy, res)
        return M, dx, dy, True
    if x0 < 0 or y0 < 0 or x0 + 1 >= w or y0 + 1 >= h:
        return 0.0, 0.0, 0.0, False
    M, dx, dy = bilinear(L[y0, x0], L[y0, x0 + 1], L[y0 + 1, x0], L[y0 + 1, x0 + 1], fx, fy, res, kind == 1)
    return M, dx, dy, True


#: ``kind`` of :func:`_interp`
BILINEAR, HECTOR_BILINEAR, BICUBIC = 0, 1, 2


@njit(cache=True, inline="always")
def _catmull_rom(p0, p1, p2, p3, f):
    """The cubic Hermite spline through p1 (f = 0) and p2 (f = 1) with slopes (p2 − p0)/2, (p3 − p1)/2, and its
    derivative in f (Ceres' CubicHermiteSpline)."""
    a = 0.5 * (-p0 + 3.0 * p1 - 3.0 * p2 + p3)
    b = 0.5 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3)
    c = 0.5 * (p2 - p0)
    return p1 + f * (c + f * (b + f * a)), c + f * (2.0 * b + 3.0 * f * a)


@njit(cache=True, inline="always")
def _catmull_rom_row(L, y, x0, fx):
    """:func:`_catmull_rom` along row y through the probabilities of cells x0 − 1 … x0 + 2."""
    return _catmull_rom(_p(L[y, x0 - 1]), _p(L[y, x0]), _p(L[y, x0 + 1]), _p(L[y, x0 + 2]), fx)


@njit(cache=True)
def bicubic(L, x0, y0, fx, fy, res):
    """(M, ∂M/∂x, ∂M/∂y) from the log-odds of the 4 × 4 cells (x0 − 1 … x0 + 2, y0 − 1 … y0 + 2) around a point at
    fractions (fx, fy) of cell (x0, y0): Catmull-Rom along x in each row, then along y (module docstring)."""
    r0, d0 = _catmull_rom_row(L, y0 - 1, x0, fx)
    r1, d1 = _catmull_rom_row(L, y0, x0, fx)
    r2, d2 = _catmull_rom_row(L, y0 + 1, x0, fx)
    r3, d3 = _catmull_rom_row(L, y0 + 2, x0, fx)
    M, dy = _catmull_rom(r0, r1, r2, r3, fy)
    dx, _ = _catmull_rom(d0, d1, d2, d3, fy)
    return M, dx / res, dy / res


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
def interpolate(L, ox, oy, res, xy, bug=False, cubic=False):
    """Vectorised :func:`_interp` over world points ``xy`` (N, 2) → (N, 3) [M, ∂M/∂x, ∂M/∂y]; bicubic with ``cubic``,
    else bilinear (with Hector's gradient weights with ``bug``)."""
    kind = BICUBIC if cubic else (HECTOR_BILINEAR if bug else BILINEAR)
    out = np.zeros((xy.shape[0], 3))
    for i in range(xy.shape[0]):
        M, dx, dy, _ = _interp(L, ox, oy, res, xy[i, 0], xy[i, 1], kind)
        out[i, 0] = M
        out[i, 1] = dx
        out[i, 2] = dy
    return out


@njit(cache=True)
def _normal_equations(L, ox, oy, res, pts, x, y, th, kind):
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
        M, dMx, dMy, inside = _interp(L, ox, oy, res, x + c * sx - s * sy, y + s * sx + c * sy, kind)
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
def _objective(ssr, W, prior, x, y, th):
    """½ Σ r² + ½ eᵀWe and We (3,), e = ξ̂ − ξ (ξ̂ and ξ on the same branch of the angle throughout a match)."""
    e = np.empty(3)
    e[0] = prior[0] - x
    e[1] = prior[1] - y
    e[2] = prior[2] - th
    We = W @ e
    return 0.5 * ssr + 0.5 * (e @ We), We


@njit(cache=True)
def _evaluate(L, ox, oy, res, pts, x, y, th, kind, W, prior):
    """H, g, Σ r², Σ M, n (:func:`_normal_equations`), F and We (:func:`_objective`) at the pose (x, y, th)."""
    H, g, ssr, msum, n = _normal_equations(L, ox, oy, res, pts, x, y, th, kind)
    f, We = _objective(ssr, W, prior, x, y, th)
    return H, g, ssr, msum, n, f, We


@njit(cache=True, inline="always")
def _parabola_minimum(f0, slope, alpha, fa):
    """The minimiser of the parabola through F(0) = f0 with F'(0) = slope < 0 and F(α) = fa; +∞ when it is not convex."""
    curvature = (fa - f0 - slope * alpha) / (alpha * alpha)
    return -slope / (2.0 * curvature) if curvature > 0.0 else np.inf


@njit(cache=True)
def solve_level(
    L,
    ox,
    oy,
    res,
    pts,
    pose,
    iterations,
    tol_t,
    tol_r,
    max_step_t,
    max_step_r,
    kind,
    prior,
    W,
    T,
    keep,
    line_search=False,
):
    """Gauss-Newton on one grid from ``pose``; returns (pose, H, ssr, Σ M, n, iterations).

    Minimises F = ½ Σ r² + ½ eᵀWe (e = ξ̂ − ξ towards ``prior`` ξ̂, W (3, 3)). The direction d = T c solves
    (TᵀAT) c = Tᵀb (A = H + W, b = g + We; where ``keep[0]`` is 0 over (c_1, c_2) only, c_0 = 0: module docstring,
    "Degeneracy"), clamped to (max_step_t, max_step_r). Without ``line_search`` the step is d (Hector's iteration);
    with it α d, α from the line search of the module docstring ("Iteration"), and the level also stops when no
    α ≥ ``ALPHA_MIN`` lowers F. The level stops after a step below (tol_t, tol_r).
    """
    x, y, th = pose[0], pose[1], pose[2]
    H, g, ssr, msum, n, f, We = _evaluate(L, ox, oy, res, pts, x, y, th, kind, W, prior)
    it = 0
    for it in range(1, iterations + 1):
        if n < 3:
            break
        if keep[0] == 0.0:
            A = T.T @ (H + W) @ T
            b = T.T @ (g + We)
            A[0, :] = 0.0
            A[:, 0] = 0.0
            A[0, 0] = 1.0
            b[0] = 0.0
            c, ok = _solve3(A, b)
            d = T @ c
        else:
            d, ok = _solve3(H + W, g + We)
        if not ok:
            break
        if not line_search:  # Hector's undamped step
            x, y, th, converged = take_step(d, x, y, th, max_step_t, max_step_r, tol_t, tol_r)
            H, g, ssr, msum, n, f, We = _evaluate(L, ox, oy, res, pts, x, y, th, kind, W, prior)
            if converged:
                break
            continue
        nx, ny, nth, _ = take_step(d, x, y, th, max_step_t, max_step_r, 0.0, 0.0)
        d = np.array([nx - x, ny - y, nth - th])
        slope = -((g + We) @ d)  # dF(ξ + αd)/dα at α = 0, < 0 (A positive definite)
        alpha = 1.0
        while True:
            trial = _evaluate(
                L, ox, oy, res, pts, x + alpha * d[0], y + alpha * d[1], th + alpha * d[2], kind, W, prior
            )
            best = _parabola_minimum(f, slope, alpha, trial[5])
            if trial[4] >= 3 and trial[5] < f:
                if best < 0.9 * alpha:  # F is lower, and lower still towards the parabola's minimum: try it
                    shorter = max(best, 0.1 * alpha)
                    other = _evaluate(
                        L, ox, oy, res, pts, x + shorter * d[0], y + shorter * d[1], th + shorter * d[2], kind, W, prior
                    )
                    if other[4] >= 3 and other[5] < trial[5]:
                        alpha, trial = shorter, other
                break
            if alpha < ALPHA_MIN:
                break
            alpha = min(max(best, 0.1 * alpha), 0.5 * alpha)
        if not trial[5] < f or trial[4] < 3:
            break
        x, y, th = x + alpha * d[0], y + alpha * d[1], th + alpha * d[2]
        H, g, ssr, msum, n, f, We = trial
        if np.hypot(alpha * d[0], alpha * d[1]) < tol_t and abs(alpha * d[2]) < tol_r:
            break
    return np.array([x, y, th]), H, ssr, msum, n, it


#: the shortest step (as a fraction of the Gauss-Newton step) the line search tries before the level stops
ALPHA_MIN = 1e-3


class GaussNewtonMatcherParams(Params):
    """Parameters of :class:`GaussNewtonMatcher`.

    The prior weights add ``w_t‖t − t̂‖² + w_r(ψ − ψ̂)²`` towards the guess ξ̂ to the objective, as Cartographer's
    Ceres matcher does (on sim:laser, pure Hector jumps 0.2–0.3 m along the first corridor;
    research/method/grid_mapping.md). Default 100 each, small against the map's H (10⁴–10⁵ per m² in constrained
    directions); 0 gives Hector's objective exactly (and no degeneracy handling: it needs the prior as its fallback).
    ``degeneracy_threshold``: 0.003 lies between a plain corridor's λ_0/λ_1 (≤ 5 · 10⁻⁴, the normals' noise) and every
    scan of the simulated ``rooms`` and ``loop`` worlds (≥ 1.3 · 10⁻²); off by default because on FR-Clinic it raised grid
    SLAM's relation error (research/method/laser_degeneracy.md).
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
    line_search: bool = Field(
        False,
        description="step along the Gauss-Newton direction by a line search on the objective (a descent that "
        "converges; module docstring, 'Iteration'); False: Hector's undamped step",
    )
    interpolation: Literal["bilinear", "bicubic"] = Field(
        "bilinear", description="the map's interpolant: bilinear (Hector) or bicubic (Catmull-Rom, as Cartographer)"
    )
    hector_gradient_bug: bool = Field(
        False, description="bilinear only: reproduce the gradient weights of Hector's published code (module docstring)"
    )
    prior_translation_weight: NonNegativeFloat = Field(
        100.0,
        description="w_t of the prior towards the guess [1/m²] when no odometry prior is given; 0: Hector's objective",
    )
    prior_rotation_weight: NonNegativeFloat = Field(
        100.0,
        description="w_r of the prior towards the guess [1/rad²] when no odometry prior is given; 0: Hector's objective",
    )
    skip_unobserved: bool = Field(
        False,
        description="leave out of the match the end points whose finest-level cell at the guess nothing has observed "
        "(log-odds at the prior's): the frontier pull (module docstring, 'Unobserved cells')",
    )
    search_below_score: NonNegativeFloat = Field(
        0.0,
        description="when a match's score is below this, match again from the best pose of a correlative search "
        "around the guess and keep the higher-scoring (module docstring, 'A poor match'); 0, the default: off "
        "(0.5 is the score of end points on unobserved cells)",
    )
    search_window: tuple[NonNegativeFloat, NonNegativeFloat] = Field(
        (0.1, 0.349),
        description="the correlative search's half-widths (translation [m], rotation [rad]): Cartographer's "
        "real-time correlative scan matcher's defaults, 0.1 m and 20°",
    )
    degeneracy_threshold: NonNegativeFloat = Field(
        0.0,
        description="τ: when the guess carries odometry and the translation information of the scan's geometry is "
        "below τ times its largest along a direction, that direction keeps the guess (module docstring, "
        "'Degeneracy'); 0, the default: off (0.003 separates the simulated corridor from the simulated rooms)",
    )

    @model_validator(mode="after")
    def _bug_is_bilinear(self):
        if self.hector_gradient_bug and self.interpolation != "bilinear":
            raise ValueError(
                "hector_gradient_bug: the published gradient weights are bilinear's (interpolation: bilinear)"
            )
        return self

    @property
    def kind(self) -> int:
        """The interpolant as :func:`_interp`'s ``kind``."""
        if self.interpolation == "bicubic":
            return BICUBIC
        return HECTOR_BILINEAR if self.hector_gradient_bug else BILINEAR


class GaussNewtonMatcher:
    """Hector-style multi-resolution Gauss-Newton scan-to-map matcher (module docstring, :class:`GaussNewtonMatcherParams`)."""

    kind = "grid"
    takes_odometry = True
    Params = GaussNewtonMatcherParams

    def __init__(self, params: GaussNewtonMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def match(self, maps, points: np.ndarray, guess: np.ndarray, odometry: bool = False) -> MatchResult:
        """The match of ``points`` (N, 2) against ``maps`` from ``guess`` (3,); ``odometry``: the guess carries the
        odometry's motion, and the directions the scan does not constrain keep it (module docstring, "Degeneracy");
        below ``search_below_score`` also from a correlative search's best pose (module docstring, "A poor match")."""
        every = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        guess = np.asarray(guess, dtype=np.float64)
        result = self._match(maps, every, guess, odometry)
        if not result.score < self.params.search_below_score:
            return result
        linear, angular = self.params.search_window
        seed = CorrelativeMatcher(linear_window=linear, angular_window=angular).match(maps, every, guess)
        again = self._match(maps, every, seed.pose, odometry)
        better = again.score > result.score
        chosen = again if better else result
        chosen.info.update(searched=1, from_search=int(better))
        return chosen

    def _match(self, maps, every: np.ndarray, guess: np.ndarray, odometry: bool) -> MatchResult:
        p = self.params
        pts = every[observed(maps.levels[0], every, guess)] if p.skip_unobserved else every
        W = np.diag([p.prior_translation_weight, p.prior_translation_weight, p.prior_rotation_weight])
        fusion = degenerate_basis(maps.levels[0], pts, guess, p) if odometry else None
        T, keep = (_I3, _KEEP) if fusion is None else (fusion.T, fusion.keep)
        pose = guess.copy()
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
                p.kind,
                guess,
                W,
                T,
                keep,
                p.line_search,
            )
            total += it
        # not wrap_angle, whose last bit differs: with Hector's undamped iteration (the default) a last-bit change of
        # the guess moves laser graph SLAM on MIT-CSAIL from 0.031 to 1.30 m; with line_search and the bicubic map
        # the match does not depend on it (research/method/laser_degeneracy.md, "The branch cut")
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        score = msum / n if n else 0.0
        if p.skip_unobserved:  # the score over every end point, as without the option
            fine = maps.levels[0]
            _, _, _, m_all, n_all = _normal_equations(
                fine.log_odds, *fine.origin, fine.params.resolution, every, *pose, p.kind
            )
            score = m_all / n_all if n_all else 0.0
        info = {"points_on_map": n, "information": match_information(H, ssr, n, fusion)}
        if fusion is None:
            cov = _laplace_covariance(H, ssr, n)
        else:
            cov = fusion.covariance(H, ssr, n)
            info["degenerate"] = int(np.sum(keep == 0.0))
        return MatchResult(pose=pose, cov=cov, score=score, iterations=total, info=info)


def observed(grid, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Whether each end point s_i (N, 2, robot frame) at ``pose`` falls on a cell of ``grid`` that something has
    observed (log-odds ≠ the prior's l0) (N,) bool; False outside the grid (module docstring, "Unobserved cells")."""
    ij = grid.world_to_grid(transform_points(pose, points))
    inside = grid.contains(ij)
    seen = np.zeros(len(points), dtype=bool)
    seen[inside] = grid.log_odds[ij[inside, 1], ij[inside, 0]] != grid.l0
    return seen


_I3 = np.eye(3)
_KEEP = np.ones(3)


@dataclass
class Fusion:
    """A degenerate match (module docstring, "Degeneracy"): ``info`` = Λ = W/σ̂² (3, 3), the odometry's information;
    ``s2`` = σ̂² at the guess; ``T`` (3, 3) = blockdiag([u_0 u_1], 1), the translation eigenvectors of the scan's
    geometric information (orthonormal); ``lam`` (2,) their eigenvalues; ``keep`` (3,) 0 for u_0, the degenerate one."""

    info: np.ndarray
    s2: float
    T: np.ndarray
    lam: np.ndarray
    keep: np.ndarray

    def covariance(self, H: np.ndarray, ssr: float, n: int) -> np.ndarray:
        """Σ = T (K Tᵀ(H/σ̂²)T K + TᵀΛT)⁻¹ Tᵀ (3, 3) at the match (H, σ̂² = ssr / (n − 3) there; T orthonormal,
        K = diag(keep)): the scan's information in the kept directions plus the odometry's (the posterior of the
        fused objective); along the degenerate direction the odometry's variance."""
        s2 = ssr / (n - 3) if n > 3 and ssr > 0 else self.s2
        K = np.diag(self.keep)
        Hc = K @ self.T.T @ (H / s2) @ self.T @ K
        return self.T @ np.linalg.inv(Hc + self.T.T @ self.info @ self.T) @ self.T.T

    def kept(self, information: np.ndarray) -> np.ndarray:
        """``information`` (3, 3, world frame) projected onto the kept directions: P I Pᵀ, P = T K Tᵀ."""
        P = self.T @ np.diag(self.keep) @ self.T.T
        return P @ information @ P.T


def match_information(H: np.ndarray, ssr: float, n: int, fusion: Fusion | None) -> np.ndarray:
    """The information (3, 3, world frame) the scan's match carries about the pose, without the prior: H/σ̂² at the
    match (σ̂² = ssr / (n − 3)), projected onto the kept directions for a degenerate match (:meth:`Fusion.kept`);
    zero with fewer than four points on the map or a perfect fit. Laser graph SLAM fuses it with the odometry's
    covariance accumulated between its nodes (:mod:`slamarena.mapping.laser_slam.interval`)."""
    if n <= 3 or not ssr > 0:
        return np.zeros((3, 3))
    information = H / (ssr / (n - 3))
    return information if fusion is None else fusion.kept(information)


def scan_information(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """The information (3, 3) the scan's own geometry carries about its pose ξ (module docstring, "Degeneracy"):
    Σ_i J_iᵀJ_i over the end points s_i (N, 2) whose neighbourhood fits a line, J_i = n_iᵀ[I₂, R'(ψ) s_i] with
    n_i that line's unit normal in the world frame (the point-to-line ICP's normals and Jacobian)."""
    from .point_to_line import PointToLineICPMatcher, residuals_and_jacobian

    ref = PointToLineICPMatcher().prepare(points)
    ok = np.isfinite(ref.normals[:, 0])
    c, s = np.cos(pose[2]), np.sin(pose[2])
    n = ref.normals[ok] @ np.array([[c, s], [-s, c]])  # R(ψ) n
    world = ref.points[ok] @ np.array([[c, s], [-s, c]]) + pose[:2]
    _, J = residuals_and_jacobian(pose, ref.points[ok], world, n)
    return J.T @ J


def degenerate_basis(grid, pts: np.ndarray, guess: np.ndarray, params) -> Fusion | None:
    """The :class:`Fusion` of a match from ``guess`` whose scan is degenerate in translation (module docstring,
    "Degeneracy"), else None: the eigenvectors u_0, u_1 of the translation block of the scan's geometric information
    I_s (:func:`scan_information`), degenerate when λ_0 < τ λ_1; σ̂² of the map match at the guess on the finest
    ``grid`` and the odometry's information Λ = W/σ̂² (W the prior weights). None also when a prior weight is zero or
    fewer than four end points fall on the grid or their residuals vanish (the match then runs as without odometry)."""
    w = np.array([params.prior_translation_weight, params.prior_translation_weight, params.prior_rotation_weight])
    if not np.all(w > 0) or params.degeneracy_threshold == 0:
        return None
    lam, U = np.linalg.eigh(scan_information(pts, guess)[:2, :2])  # ascending
    if not lam[0] < params.degeneracy_threshold * lam[1]:
        return None
    _, _, ssr, _, n = _normal_equations(
        grid.log_odds, grid.origin[0], grid.origin[1], grid.params.resolution, pts, *guess, params.kind
    )
    if n <= 3 or not ssr > 0:
        return None
    s2 = ssr / (n - 3)
    T = np.eye(3)
    T[:2, :2] = U
    return Fusion(info=np.diag(w / s2), s2=s2, T=T, lam=lam, keep=np.array([0.0, 1.0, 1.0]))


def _laplace_covariance(H: np.ndarray, ssr: float, n: int) -> np.ndarray:
    eig = (
        np.linalg.eigvalsh(H) if n > 3 else np.zeros(3)
    )  # ascending; H is symmetric: its condition number is eig[-1] / eig[0]
    if not eig[0] * 1e12 >= eig[-1] > 0:
        return np.diag([np.inf, np.inf, np.inf])
    return ssr / (n - 3) * np.linalg.inv(H)
