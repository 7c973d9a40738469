"""Perspective-n-Point: the camera pose ``T_cam←world = (R, t)`` from world points X (n, 3) and their images.

**P3P** (Grunert 1841, as reviewed by Haralick et al. 1994; solved here by a resultant). Unit bearings f_i (3,) of
three points, distances s_i along them, ``a = |X₂ − X₃|, b = |X₁ − X₃|, c = |X₁ − X₂|``, ``cos α = f₂·f₃,
cos β = f₁·f₃, cos γ = f₁·f₂``. With s₂ = u s₁, s₃ = v s₁ the law of cosines gives ::

    s₁² (u² + v² − 2uv cos α) = a²,   s₁² (1 + v² − 2v cos β) = b²,   s₁² (1 + u² − 2u cos γ) = c²

Eliminating s₁² leaves two quadratics in u whose coefficients are polynomials in v,
``Q₁ = b² u² − 2b² v cos α · u + b² v² − a² (1 + v² − 2v cos β)`` and
``Q₂ = b² u² − 2b² cos γ · u + b² − c² (1 + v² − 2v cos β)``; their resultant in u ::

    (p₂q₀ − p₀q₂)² − (p₂q₁ − p₁q₂)(p₁q₀ − p₀q₁) = 0        (a quartic in v: up to four solutions)

and ``u = (q₀ − p₀)/(p₁ − q₁)`` (Q₁ − Q₂ is linear in u), ``s₁ = b / √(1 + v² − 2v cos β)``. The camera-frame points
s_i f_i and the world points give (R, t) by the absolute orientation of :func:`absolute_orientation`.

**EPnP** (Lepetit, Moreno-Noguer & Fua 2009). Four control points c_j (the centroid and the principal axes of X),
barycentric weights α (n, 4) with X_i = Σ_j α_ij c_j and Σ_j α_ij = 1. In the camera the same weights hold; each
observation x_i = (x, y) (normalised) gives two linear equations in the 12 camera-frame control coordinates ::

    Σ_j α_ij (c_j,x − x c_j,z) = 0,   Σ_j α_ij (c_j,y − y c_j,z) = 0           M (2n, 12) · c = 0

c = Σ_k β_k v_k over the four eigenvectors v_k of MᵀM (12, 12) of the smallest eigenvalues (MᵀM = Σ_i α_iα_iᵀ ⊗
[[1, 0, −x], [0, 1, −y], [−x, −y, x² + y²]], accumulated point by point). The six inter-control distances
``||c_a − c_b||² = ||c_a^w − c_b^w||² = ρ_ab`` are ``L (6, 10) · (β₁β₁, β₁β₂, β₂β₂, β₁β₃, β₂β₃, β₃β₃, β₁β₄, …, β₄β₄) = ρ``;
Lepetit's three linearisations (least squares over the columns of (β₁β₁, β₁β₂, β₁β₃, β₁β₄), (β₁β₁, β₁β₂, β₂β₂) and
(β₁β₁, β₁β₂, β₂β₂, β₁β₃, β₂β₃)) start five Gauss-Newton steps on all four β (J (6, 4)); the pose is the absolute
orientation of Σ_j α_ij c_j onto X_i, and the start of the smallest mean reprojection distance wins (OpenCV's
``SOLVEPNP_EPNP`` does the same).

**Kernels.** P3P, EPnP, the hypothesis loop of RANSAC and LM are numba kernels (scalar loops over points: no
temporary per point); ``tests/estimators/test_vision_pnp_kernels.py`` holds their literal numpy forms.

**RANSAC** (:func:`pnp_ransac`): minimal samples of 3 (P3P, each of its solutions scored) or 6 (EPnP), inliers by
reprojection error in pixels, adaptive number of samples (:mod:`.ransac`), EPnP (non-planar points) or DLS
(:mod:`.dls`, ``nonminimal="dls"``, planar points too) on all inliers, kept if its reprojection error is smaller,
then :func:`refine_pose` on the inliers and re-classification, repeated until the inlier set is stable (≤ 5 rounds).

**Refinement** (:func:`refine_pose`): Levenberg-Marquardt on SE(3), residuals and Jacobians of :mod:`.projection`,
``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀ r``, ``T ← exp(δ^) T``, λ × 10 on a rejected step, ÷ 10 on an accepted one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .dls import dls
from .lie import se3_exp_kernel
from .projection import normalise, residuals
from .ransac import iterations_needed

__all__ = [
    "absolute_orientation",
    "planar",
    "p3p",
    "epnp",
    "refine_pose",
    "pnp_ransac",
    "PnPResult",
    "OptimisationError",
]

#: EPnP refuses points whose smallest principal spread is below this fraction of the largest (:func:`planar`)
PLANAR_RATIO = 1e-3


class OptimisationError(RuntimeError):
    """A pose refinement that cannot produce a result (no valid point, non-finite cost)."""


@numba.njit(cache=True)
def absolute_orientation(X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) minimising Σ ||Y_i − (R X_i + t)||² (Kabsch/Umeyama without scale; X, Y (n, 3), n ≥ 3)."""
    n = X.shape[0]
    mx, my = np.zeros(3), np.zeros(3)
    for i in range(n):
        mx += X[i]
        my += Y[i]
    mx, my = mx / n, my / n
    H = np.zeros((3, 3))  # Σ (Y_i − m_y)(X_i − m_x)ᵀ
    for i in range(n):
        for r in range(3):
            for c in range(3):
                H[r, c] += (Y[i, r] - my[r]) * (X[i, c] - mx[c])
    U, _, Vt = np.linalg.svd(H)
    d = np.linalg.det(U @ Vt)
    U[:, 2] *= -1.0 if d < 0 else 1.0
    R = U @ Vt
    return R, my - R @ mx


@numba.njit(cache=True, inline="always")
def _transform(R: np.ndarray, t: np.ndarray, X: np.ndarray) -> tuple[float, float, float]:
    """R X + t of one point as three scalars (no temporary array in the compiled loops)."""
    return (
        R[0, 0] * X[0] + R[0, 1] * X[1] + R[0, 2] * X[2] + t[0],
        R[1, 0] * X[0] + R[1, 1] * X[1] + R[1, 2] * X[2] + t[1],
        R[2, 0] * X[0] + R[2, 1] * X[1] + R[2, 2] * X[2] + t[2],
    )


@numba.njit(cache=True)
def _real_roots(c: np.ndarray) -> np.ndarray:
    """The real roots of the polynomial with coefficients c (high → low), |Im| ≤ 1e-6 max(1, |Re|) (``np.roots``'
    companion matrix, as the literal form)."""
    first = 0
    while first < len(c) and c[first] == 0.0:
        first += 1
    last = len(c)
    while last > first and c[last - 1] == 0.0:
        last -= 1
    degree = last - first - 1
    zeros = len(c) - last
    out = np.zeros(max(degree, 0) + zeros)
    count = 0
    if degree >= 1:
        A = np.zeros((degree, degree), dtype=np.complex128)
        for k in range(degree):
            A[0, k] = -c[first + 1 + k] / c[first]
        for k in range(1, degree):
            A[k, k - 1] = 1.0
        for r in np.linalg.eigvals(A):
            if abs(r.imag) <= 1e-6 * max(1.0, abs(r.real)):
                out[count] = r.real
                count += 1
    return out[:count]  # a root at 0 gives v = 0, which P3P rejects: not returned


@numba.njit(cache=True)
def _p3p_kernel(X: np.ndarray, f: np.ndarray, Rs: np.ndarray, ts: np.ndarray) -> int:
    """The poses of :func:`p3p` written into Rs (4, 3, 3), ts (4, 3) from world X (3, 3) and unit bearings f (3, 3);
    returns how many."""
    a2 = np.sum((X[1] - X[2]) ** 2)
    b2 = np.sum((X[0] - X[2]) ** 2)
    c2 = np.sum((X[0] - X[1]) ** 2)
    if a2 <= 0 or b2 <= 0 or c2 <= 0:
        return 0
    ca, cb, cg = f[1] @ f[2], f[0] @ f[2], f[0] @ f[1]
    # polynomials in v, coefficients low → high: w = 1 − 2v cos β + v², Q₁ = p₂u² + p₁u + p₀, Q₂ = q₂u² + q₁u + q₀
    w = np.array([1.0, -2.0 * cb, 1.0])
    p2, p1, p0 = np.array([b2, 0.0, 0.0]), np.array([0.0, -2.0 * b2 * ca, 0.0]), np.array([0.0, 0.0, b2]) - a2 * w
    q2, q1, q0 = np.array([b2, 0.0, 0.0]), np.array([-2.0 * b2 * cg, 0.0, 0.0]), np.array([b2, 0.0, 0.0]) - c2 * w
    d20 = np.convolve(p2, q0) - np.convolve(p0, q2)
    d21 = np.convolve(p2, q1) - np.convolve(p1, q2)
    d10 = np.convolve(p1, q0) - np.convolve(p0, q1)
    quartic = (np.convolve(d20, d20) - np.convolve(d21, d10))[:5]  # degree 4: the higher terms cancel
    count = 0
    Y = np.empty((3, 3))
    for v in _real_roots(quartic[::-1].copy()):
        powers = np.array([1.0, v, v * v])
        denominator = (p1 - q1) @ powers
        if v <= 0 or abs(denominator) < 1e-12:
            continue
        u = (q0 - p0) @ powers / denominator
        s1_squared = b2 / (w @ powers)
        if u <= 0 or not s1_squared > 0:
            continue
        s1 = np.sqrt(s1_squared)
        Y[0], Y[1], Y[2] = s1 * f[0], u * s1 * f[1], v * s1 * f[2]
        Rs[count], ts[count] = absolute_orientation(X, Y)
        count += 1
    return count


@numba.njit(cache=True)
def _bearings(x: np.ndarray) -> np.ndarray:
    """Unit bearings (n, 3) of normalised points x (n, 2)."""
    f = np.empty((x.shape[0], 3))
    for i in range(x.shape[0]):
        norm = np.sqrt(x[i, 0] ** 2 + x[i, 1] ** 2 + 1.0)
        f[i, 0], f[i, 1], f[i, 2] = x[i, 0] / norm, x[i, 1] / norm, 1.0 / norm
    return f


def p3p(X: np.ndarray, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every pose (R, t) (at most four) that projects the three world points X (3, 3) to the normalised x (3, 2)."""
    Rs, ts = np.empty((4, 3, 3)), np.empty((4, 3))
    count = _p3p_kernel(np.ascontiguousarray(X, dtype=float), _bearings(np.ascontiguousarray(x, dtype=float)), Rs, ts)
    return [(Rs[k], ts[k]) for k in range(count)]


@numba.njit(cache=True)
def _principal_axes(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid (3,), variances (3,) ascending and axes (3, 3) (columns) of X (n, 3)."""
    c0 = np.zeros(3)
    for i in range(X.shape[0]):
        c0 += X[i]
    c0 /= X.shape[0]
    C = np.zeros((3, 3))
    for i in range(X.shape[0]):
        for r in range(3):
            for c in range(r, 3):
                C[r, c] += (X[i, r] - c0[r]) * (X[i, c] - c0[c])
    for r in range(3):
        for c in range(r):
            C[r, c] = C[c, r]
    values, vectors = np.linalg.eigh(C / X.shape[0])
    return c0, values, vectors


def planar(X: np.ndarray, ratio: float = PLANAR_RATIO) -> bool:
    """Whether the points X (n, 3) lie (within ``ratio`` of their largest spread) on a plane: EPnP's control
    points then span no volume, and the barycentric weights are not defined."""
    _, values, _ = _principal_axes(np.ascontiguousarray(X, dtype=float))
    spread = np.sqrt(np.maximum(values, 0.0))
    return bool(spread[0] <= ratio * spread[2])


_PAIRS = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
#: the ten products β_kβ_l of EPnP's L (6, 10), in Lepetit's order B11 B12 B22 B13 B23 B33 B14 B24 B34 B44
_PRODUCTS = np.array([(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2), (0, 3), (1, 3), (2, 3), (3, 3)])


@numba.njit(cache=True)
def _least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """argmin ||A z − b|| for a small A (m, n), m ≥ n, of full column rank: Householder QR, then back substitution
    (as Lepetit's ``qr_solve``; no LAPACK call for EPnP's 6 × 3 … 6 × 5 systems)."""
    A, b = A.copy(), b.copy()
    m, n = A.shape
    for k in range(n):
        norm = np.sqrt(np.sum(A[k:, k] ** 2))
        if norm == 0.0:
            continue
        alpha = -norm if A[k, k] > 0 else norm
        v = A[k:, k].copy()
        v[0] -= alpha
        vv = np.sum(v**2)
        if vv == 0.0:
            continue
        for j in range(k, n):  # A ← (I − 2 v vᵀ / vᵀv) A, b likewise
            A[k:, j] -= 2.0 * (v @ A[k:, j]) / vv * v
        b[k:] -= 2.0 * (v @ b[k:]) / vv * v
    z = np.zeros(n)
    for k in range(n - 1, -1, -1):
        z[k] = (b[k] - A[k, k + 1 : n] @ z[k + 1 :]) / A[k, k] if A[k, k] != 0.0 else 0.0
    return z


@numba.njit(cache=True)
def _epnp_kernel(X: np.ndarray, x: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray]:
    """EPnP of :func:`epnp`; (False, ·, ·) when the points are planar."""
    n = X.shape[0]
    c0, values, vectors = _principal_axes(X)
    spread = np.sqrt(np.maximum(values, 0.0))
    if spread[0] <= PLANAR_RATIO * spread[2]:
        return False, np.eye(3), np.zeros(3)
    cw = np.empty((4, 3))
    cw[0] = c0
    for k in range(3):
        cw[k + 1] = c0 + spread[k] * vectors[:, k]
    B = np.ones((4, 4))
    B[:, 1:] = cw
    Binv = np.linalg.inv(B)
    alphas = np.empty((n, 4))  # X_i = Σ_j α_ij c_j
    MtM = np.zeros((12, 12))  # = Σ_i (α_i α_iᵀ) ⊗ C_i, C_i = [[1, 0, −x], [0, 1, −y], [−x, −y, x² + y²]]
    for i in range(n):
        for j in range(4):
            alphas[i, j] = Binv[0, j] + X[i, 0] * Binv[1, j] + X[i, 1] * Binv[2, j] + X[i, 2] * Binv[3, j]
        xi, yi = x[i, 0], x[i, 1]
        for j in range(4):
            for k in range(j, 4):
                a = alphas[i, j] * alphas[i, k]
                MtM[3 * j, 3 * k] += a
                MtM[3 * j + 1, 3 * k + 1] += a
                MtM[3 * j, 3 * k + 2] -= a * xi
                MtM[3 * j + 1, 3 * k + 2] -= a * yi
                MtM[3 * j + 2, 3 * k] -= a * xi
                MtM[3 * j + 2, 3 * k + 1] -= a * yi
                MtM[3 * j + 2, 3 * k + 2] += a * (xi * xi + yi * yi)
    for j in range(4):  # the lower blocks by symmetry
        for k in range(j):
            MtM[3 * j : 3 * j + 3, 3 * k : 3 * k + 3] = MtM[3 * k : 3 * k + 3, 3 * j : 3 * j + 3].T
    V = np.ascontiguousarray(np.linalg.eigh(MtM)[1][:, :4].T)  # (4, 12): the kernel vectors, smallest first
    rho = np.empty(6)
    L = np.empty((6, 10))  # ||Σ_k β_k (v_k,a − v_k,b)||² = L · (β_kβ_l) products
    for p in range(6):
        a, b = _PAIRS[p]
        rho[p] = np.sum((cw[a] - cw[b]) ** 2)
        D = V[:, 3 * a : 3 * a + 3] - V[:, 3 * b : 3 * b + 3]
        for q in range(10):
            k, m = _PRODUCTS[q]
            L[p, q] = (1.0 if k == m else 2.0) * (D[k] @ D[m])
    best_R, best_t, best_error = np.eye(3), np.zeros(3), np.inf
    for N in (1, 2, 3):  # Lepetit's three linearisations, each refined by Gauss-Newton on the four β
        betas = np.zeros(4)
        if N == 1:  # B11 B12 B13 B14
            s = _least_squares(L[:, np.array([0, 1, 3, 6])], rho)
            betas[0] = np.sqrt(abs(s[0]))
            sign = -1.0 if s[0] < 0 else 1.0
            betas[1:] = sign * s[1:] / betas[0]
        else:  # B11 B12 B22 (N = 2), + B13 B23 (N = 3)
            s = _least_squares(L[:, :3] if N == 2 else L[:, :5], rho)
            if s[0] < 0:
                betas[0], betas[1] = np.sqrt(-s[0]), np.sqrt(-s[2]) if s[2] < 0 else 0.0
            else:
                betas[0], betas[1] = np.sqrt(s[0]), np.sqrt(s[2]) if s[2] > 0 else 0.0
            if s[1] < 0:
                betas[0] = -betas[0]
            if N == 3:
                betas[2] = s[3] / betas[0]
        for _ in range(5):  # Gauss-Newton on the six distances, J (6, 4) = ∂(L·products)/∂β
            J, r = np.zeros((6, 4)), rho.copy()
            for q in range(10):
                k, m = _PRODUCTS[q]
                r -= L[:, q] * betas[k] * betas[m]
                J[:, k] += L[:, q] * betas[m]
                J[:, m] += L[:, q] * betas[k]
            betas += _least_squares(J, r)
        control = (betas @ V).reshape(4, 3)
        Y = alphas @ control
        if np.sum(Y[:, 2]) < 0:
            Y = -Y
        R, t = absolute_orientation(X, Y)
        error = 0.0  # mean reprojection distance (normalised), Lepetit's choice among the three
        for i in range(n):
            xc, yc, zc = _transform(R, t, X[i])
            error += np.sqrt((xc / zc - x[i, 0]) ** 2 + (yc / zc - x[i, 1]) ** 2)
        if error < best_error:
            best_R, best_t, best_error = R, t, error
    return True, best_R, best_t


def epnp(X: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pose (R, t) of n ≥ 4 (non-planar: 6 or more is well posed) world points X (n, 3) seen at normalised x (n, 2)."""
    X, x = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(x, dtype=float)
    if len(X) < 4:
        raise ValueError(f"EPnP needs at least 4 non-coplanar points, got {len(X)}")
    ok, R, t = _epnp_kernel(X, x)
    if not ok:
        raise ValueError(f"EPnP needs at least 4 non-coplanar points, got {len(X)} on a plane")
    return R, t


@numba.njit(cache=True)
def _reprojection_cost(K: np.ndarray, R: np.ndarray, t: np.ndarray, X: np.ndarray, u: np.ndarray) -> float:
    """Σ ||π(R X_i + t) − u_i||² [px²]; inf when a point is not in front of the camera."""
    cost = 0.0
    for i in range(X.shape[0]):
        x, y, z = _transform(R, t, X[i])
        if not z > 0:
            return np.inf
        cost += (K[0, 0] * x / z + K[0, 2] - u[i, 0]) ** 2 + (K[1, 1] * y / z + K[1, 2] - u[i, 1]) ** 2
    return cost


@numba.njit(cache=True)
def _refine_kernel(K, R, t, X, u, iterations, tolerance):
    """Levenberg-Marquardt of :func:`refine_pose`: H = JᵀJ and g = Jᵀr accumulated point by point."""
    current = _reprojection_cost(K, R, t, X, u)
    lam = 1e-3
    fx, fy = K[0, 0], K[1, 1]
    for _ in range(iterations):
        H, g = np.zeros((6, 6)), np.zeros(6)
        J = np.zeros((2, 6))
        for i in range(X.shape[0]):
            x, y, z = _transform(R, t, X[i])
            r0, r1 = fx * x / z + K[0, 2] - u[i, 0], fy * y / z + K[1, 2] - u[i, 1]
            # ∂r/∂ξ = ∂π/∂x_c [I | −[x_c]×]
            J[0, 0], J[0, 1], J[0, 2] = fx / z, 0.0, -fx * x / z**2
            J[0, 3], J[0, 4], J[0, 5] = -fx * x * y / z**2, fx * (1 + x * x / z**2), -fx * y / z
            J[1, 0], J[1, 1], J[1, 2] = 0.0, fy / z, -fy * y / z**2
            J[1, 3], J[1, 4], J[1, 5] = -fy * (1 + y * y / z**2), fy * x * y / z**2, fy * x / z
            for a in range(6):
                g[a] += J[0, a] * r0 + J[1, a] * r1
                for b in range(a, 6):
                    H[a, b] += J[0, a] * J[0, b] + J[1, a] * J[1, b]
        for a in range(6):
            for b in range(a):
                H[a, b] = H[b, a]
        step = np.linalg.solve(H + lam * np.diag(np.diag(H)), -g)
        dR, dt = se3_exp_kernel(step)
        R_new, t_new = dR @ R, dR @ t + dt
        new = _reprojection_cost(K, R_new, t_new, X, u)
        if new < current:
            decrease = current - new
            R, t, current, lam = R_new, t_new, new, lam / 10
            if decrease <= tolerance * max(current, 1e-300) or np.sqrt(np.sum(step**2)) < 1e-12:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return R, t, current


def refine_pose(
    K: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    X: np.ndarray,
    u: np.ndarray,
    iterations: int = 20,
    tolerance: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Levenberg-Marquardt on SE(3) from (R, t): the pose and the final RMS reprojection error [px].

    Raises :class:`OptimisationError` when a point lies behind the camera at the start or the cost is not finite."""
    X, u = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(u, dtype=float)
    K, R, t = np.asarray(K, float), np.ascontiguousarray(R, dtype=float), np.asarray(t, float).reshape(3)
    behind = int(np.sum(X @ R[2] + t[2] <= 0))
    if behind:
        raise OptimisationError(f"refine_pose: {behind} of {len(X)} points behind the camera")
    R, t, current = _refine_kernel(K, R, t, X, u, iterations, tolerance)
    if not np.isfinite(current):
        raise OptimisationError(f"refine_pose: non-finite cost {current}")
    return R, t, float(np.sqrt(current / len(X)))


@dataclass(frozen=True)
class PnPResult:
    """The pose T_cam←world, the inlier mask (n,), the RMS reprojection error of the inliers [px], samples drawn."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    rms: float
    iterations: int


@numba.njit(cache=True)
def _count_inliers(K, R, t, X, u, threshold2) -> int:
    count = 0
    for i in range(X.shape[0]):
        x, y, z = _transform(R, t, X[i])
        if z > 0:
            e0 = K[0, 0] * x / z + K[0, 2] - u[i, 0]
            e1 = K[1, 1] * y / z + K[1, 2] - u[i, 1]
            count += e0 * e0 + e1 * e1 <= threshold2
    return count


@numba.njit(cache=True)
def _ransac_kernel(K, X, x, u, minimal_p3p, threshold, confidence, max_iterations, seed):
    """The hypothesis loop of :func:`pnp_ransac`: (R, t, inlier count, samples drawn) of the best minimal pose."""
    np.random.seed(seed)
    n = X.shape[0]
    size = 3 if minimal_p3p else 6
    f = _bearings(x)
    Rs, ts = np.empty((4, 3, 3)), np.empty((4, 3))
    sample = np.empty(size, np.int64)
    best_R, best_t, best_count = np.eye(3), np.zeros(3), 0
    needed, drawn = max_iterations, 0
    while drawn < needed:
        drawn += 1
        for j in range(size):  # a sample of distinct indices
            fresh = False
            while not fresh:
                sample[j] = np.random.randint(0, n)
                fresh = True
                for k in range(j):
                    fresh = fresh and sample[k] != sample[j]
        if minimal_p3p:
            count = _p3p_kernel(X[sample], f[sample], Rs, ts)
        else:
            ok, Rs[0], ts[0] = _epnp_kernel(X[sample], x[sample])
            count = 1 if ok else 0
        for k in range(count):
            inliers = _count_inliers(K, Rs[k], ts[k], X, u, threshold * threshold)
            if inliers > best_count:
                best_R, best_t, best_count = Rs[k].copy(), ts[k].copy(), inliers
                needed = iterations_needed(inliers / n, size, confidence, max_iterations)
    return best_R, best_t, best_count, drawn


def _inliers(K, R, t, X, u, threshold) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.sum(residuals(K, R, t, X, u) ** 2, axis=1)
    return ((X @ R[2] + t[2]) > 0) & (error <= threshold**2)


def pnp_ransac(
    K: np.ndarray,
    X: np.ndarray,
    u: np.ndarray,
    threshold: float = 2.0,
    minimal: str = "p3p",
    confidence: float = 0.999,
    max_iterations: int = 1000,
    refine: bool = True,
    seed: int = 0,
    nonminimal: str = "epnp",
) -> PnPResult:
    """The pose from world points X (n, 3) and pixels u (n, 2): RANSAC over ``minimal`` solutions (``p3p`` or
    ``epnp``), inliers within ``threshold`` [px], ``nonminimal`` (``epnp`` or ``dls``) on all inliers, then LM
    (``refine``). ``seed`` (mod 2³²) seeds the kernel's sampler. ValueError when no pose has at least
    ``sample size + 1`` inliers."""
    X, u = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(u, dtype=float)
    K = np.asarray(K, float)
    size = {"p3p": 3, "epnp": 6}[minimal]
    solver = _NONMINIMAL[nonminimal]
    n = len(X)
    if n < size + 1:
        raise ValueError(f"pnp_ransac ({minimal}) needs at least {size + 1} correspondences, got {n}")
    x = normalise(K, u)
    R, t, count, drawn = _ransac_kernel(
        K, X, x, u, minimal == "p3p", float(threshold), float(confidence), int(max_iterations), int(seed) % 2**32
    )
    if count < size + 1:
        raise ValueError(f"pnp_ransac found no pose with {size + 1} inliers among {n} correspondences")
    best_inliers = _inliers(K, R, t, X, u, threshold)
    Xi, ui = X[best_inliers], u[best_inliers]
    if len(Xi) >= 6 and (nonminimal == "dls" or not planar(Xi)):  # DLS takes planar points, EPnP does not
        R_all, t_all = solver(Xi, x[best_inliers])
        if _reprojection_cost(K, R_all, t_all, Xi, ui) < _reprojection_cost(K, R, t, Xi, ui):
            R, t = R_all, t_all
    rms = float(np.sqrt(np.mean(np.sum(residuals(K, R, t, Xi, ui) ** 2, axis=1))))
    for _ in range(5 if refine else 0):  # refine on the inliers, re-classify, until the inlier set is stable
        R, t, rms = refine_pose(K, R, t, X[best_inliers], u[best_inliers])
        inliers = _inliers(K, R, t, X, u, threshold)
        if np.array_equal(inliers, best_inliers) or inliers.sum() < size + 1:
            break
        best_inliers = inliers
    return PnPResult(R, t, best_inliers, rms, int(drawn))


_NONMINIMAL = {"epnp": epnp, "dls": dls}
