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

c = Σ_k β_k v_k over the N ∈ {1, 2, 3} right singular vectors v_k of M of the smallest singular values; β from the
six inter-control distances ||c_i − c_j||² = ||c_i^w − c_j^w||², linear in the products β_k β_l (then four-β
Gauss-Newton on the same six equations); the pose is the absolute orientation of Σ_j α_ij c_j onto X_i. The N of
the smallest reprojection error is returned.

**RANSAC** (:func:`pnp_ransac`): minimal samples of 3 (P3P, each of its solutions scored) or 6 (EPnP), inliers by
reprojection error in pixels, adaptive number of samples (:mod:`.ransac`), EPnP on all inliers (non-planar points),
then :func:`refine_pose` on the inliers and re-classification, repeated until the inlier set is stable (≤ 5 rounds).

**Refinement** (:func:`refine_pose`): Levenberg-Marquardt on SE(3), residuals and Jacobians of :mod:`.projection`,
``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀ r``, ``T ← exp(δ^) T``, λ × 10 on a rejected step, ÷ 10 on an accepted one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lie import se3_exp
from .projection import jacobians, normalise, residuals
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


class OptimisationError(RuntimeError):
    """A pose refinement that cannot produce a result (no valid point, non-finite cost)."""


def absolute_orientation(X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) minimising Σ ||Y_i − (R X_i + t)||² (Kabsch/Umeyama without scale; X, Y (n, 3), n ≥ 3)."""
    mx, my = X.mean(axis=0), Y.mean(axis=0)
    U, _, Vt = np.linalg.svd((Y - my).T @ (X - mx))
    S = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])
    R = U @ S @ Vt
    return R, my - R @ mx


def _bearings(x: np.ndarray) -> np.ndarray:
    f = np.column_stack([np.asarray(x, float).reshape(-1, 2), np.ones(len(x))])
    return f / np.linalg.norm(f, axis=1, keepdims=True)


def p3p(X: np.ndarray, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Every pose (R, t) (at most four) that projects the three world points X (3, 3) to the normalised x (3, 2)."""
    X = np.asarray(X, float)
    f = _bearings(x)
    a2, b2, c2 = (np.sum((X[1] - X[2]) ** 2), np.sum((X[0] - X[2]) ** 2), np.sum((X[0] - X[1]) ** 2))
    ca, cb, cg = f[1] @ f[2], f[0] @ f[2], f[0] @ f[1]
    if b2 <= 0 or a2 <= 0 or c2 <= 0:
        return []
    # polynomials in v as coefficient arrays, low → high (np.convolve multiplies them)
    w = np.array([1.0, -2.0 * cb, 1.0])  # 1 + v² − 2v cos β
    p2, p1, p0 = np.array([b2, 0.0, 0.0]), np.array([0.0, -2.0 * b2 * ca, 0.0]), np.array([0.0, 0.0, b2]) - a2 * w
    q2, q1, q0 = np.array([b2, 0.0, 0.0]), np.array([-2.0 * b2 * cg, 0.0, 0.0]), np.array([b2, 0.0, 0.0]) - c2 * w
    d20 = np.convolve(p2, q0) - np.convolve(p0, q2)
    d21 = np.convolve(p2, q1) - np.convolve(p1, q2)
    d10 = np.convolve(p1, q0) - np.convolve(p0, q1)
    quartic = (np.convolve(d20, d20) - np.convolve(d21, d10))[:5]  # degree 4: the higher terms cancel
    roots = np.roots(quartic[::-1])
    out = []
    powers = np.array([1.0, 0.0, 0.0])
    for v in roots[np.abs(roots.imag) <= 1e-6 * np.maximum(1.0, np.abs(roots.real))].real:
        powers[1], powers[2] = v, v * v
        denominator = (p1 - q1) @ powers
        if v <= 0 or abs(denominator) < 1e-12:
            continue
        u = (q0 - p0) @ powers / denominator
        s1_squared = b2 / (w @ powers)
        if u <= 0 or not s1_squared > 0:
            continue
        s1 = np.sqrt(s1_squared)
        Y = np.array([s1, u * s1, v * s1])[:, None] * f
        out.append(absolute_orientation(X, Y))
    return out


def planar(X: np.ndarray, ratio: float = 1e-3) -> bool:
    """Whether the points X (n, 3) lie (within ``ratio`` of their largest spread) on a plane: EPnP's control
    points then span no volume, and the barycentric weights are not defined."""
    spread = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(X.T, bias=True)), 0.0))
    return bool(spread[0] <= ratio * spread[2])


def _control_points(X: np.ndarray) -> np.ndarray:
    """(4, 3): the centroid and the centroid plus each principal axis scaled by its standard deviation."""
    c0 = X.mean(axis=0)
    values, vectors = np.linalg.eigh(np.cov((X - c0).T, bias=True))
    return np.vstack([c0, c0 + (np.sqrt(np.maximum(values, 0.0)) * vectors).T])


_PAIRS = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]


def _pose_of(betas: np.ndarray, V: np.ndarray, alphas: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    control = (betas @ V).reshape(4, 3)
    Y = alphas @ control
    if np.mean(Y[:, 2]) < 0:
        Y = -Y
    return absolute_orientation(X, Y)


def _refine_betas(betas: np.ndarray, V: np.ndarray, rho: np.ndarray, iterations: int = 5) -> np.ndarray:
    """Gauss-Newton on ||Σ_k β_k (v_k,i − v_k,j)||² = ρ_ij over the six control-point pairs (four β)."""
    D = np.stack([V[:, 3 * i : 3 * i + 3] - V[:, 3 * j : 3 * j + 3] for i, j in _PAIRS])  # (6, 4, 3)
    for _ in range(iterations):
        d = np.einsum("k,pkc->pc", betas, D)  # (6, 3)
        r = np.sum(d * d, axis=1) - rho
        J = 2 * np.einsum("pc,pkc->pk", d, D)
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        betas = betas + step
    return betas


def epnp(X: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pose (R, t) of n ≥ 4 (non-planar: 6 or more is well posed) world points X (n, 3) seen at normalised x (n, 2)."""
    X, x = np.asarray(X, float), np.asarray(x, float)
    if len(X) < 4:
        raise ValueError(f"EPnP needs at least 4 non-coplanar points, got {len(X)}")
    if planar(X):
        raise ValueError(f"EPnP needs at least 4 non-coplanar points, got {len(X)} on a plane")
    cw = _control_points(X)
    alphas = np.column_stack([np.ones(len(X)), X]) @ np.linalg.inv(np.column_stack([np.ones(4), cw]))  # (n, 4)
    M = np.zeros((2 * len(X), 12))
    M[0::2, 0::3], M[0::2, 2::3] = alphas, -alphas * x[:, :1]
    M[1::2, 1::3], M[1::2, 2::3] = alphas, -alphas * x[:, 1:]
    V = np.linalg.eigh(M.T @ M)[1][:, :4].T  # (4, 12): right singular vectors of M, the smallest first
    rho = np.array([np.sum((cw[i] - cw[j]) ** 2) for i, j in _PAIRS])
    D = np.stack([V[:, 3 * i : 3 * i + 3] - V[:, 3 * j : 3 * j + 3] for i, j in _PAIRS])  # (6, 4, 3)
    best, best_error = None, np.inf
    for N in (1, 2, 3):
        products = [(k, m) for k in range(N) for m in range(k, N)]
        L = np.column_stack([(2 - (k == m)) * np.sum(D[:, k] * D[:, m], axis=1) for k, m in products])
        b = np.linalg.lstsq(L, rho, rcond=None)[0]
        squares = {k: b[products.index((k, k))] for k in range(N)}
        betas = np.zeros(4)
        betas[0] = np.sqrt(abs(squares[0]))
        for k in range(1, N):
            betas[k] = np.sqrt(abs(squares[k])) * np.sign(b[products.index((0, k))] or 1.0)
        R, t = _pose_of(_refine_betas(betas, V, rho), V, alphas, X)
        error = np.sum(residuals(np.eye(3), R, t, X, x) ** 2)
        if error < best_error:
            best, best_error = (R, t), error
    return best


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
    X, u = np.asarray(X, float), np.asarray(u, float)

    def cost(R, t):
        z = X @ R[2] + t[2]
        return np.inf if np.any(z <= 0) else float(np.sum(residuals(K, R, t, X, u) ** 2))

    current = cost(R, t)
    if not np.isfinite(current):
        raise OptimisationError(f"refine_pose: {np.sum(X @ R[2] + t[2] <= 0)} of {len(X)} points behind the camera")
    lam = 1e-3
    for _ in range(iterations):
        r = residuals(K, R, t, X, u).reshape(-1)
        J = jacobians(K, R, t, X)[0].reshape(-1, 6)
        H, g = J.T @ J, J.T @ r
        step = np.linalg.solve(H + lam * np.diag(np.diag(H)), -g)
        dR, dt = se3_exp(step)
        R_new, t_new = dR @ R, dR @ t + dt
        new = cost(R_new, t_new)
        if new < current:
            decrease = current - new
            R, t, current, lam = R_new, t_new, new, lam / 10
            if decrease <= tolerance * max(current, 1e-300) or np.linalg.norm(step) < 1e-12:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return R, t, float(np.sqrt(current / len(X)))


@dataclass(frozen=True)
class PnPResult:
    """The pose T_cam←world, the inlier mask (n,), the RMS reprojection error of the inliers [px], samples drawn."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    rms: float
    iterations: int


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
) -> PnPResult:
    """The pose from world points X (n, 3) and pixels u (n, 2): RANSAC over ``minimal`` solutions (``p3p`` or
    ``epnp``), inliers within ``threshold`` [px], EPnP on all inliers, then LM (``refine``). ValueError when no pose
    has at least ``sample size + 1`` inliers."""
    X, u = np.asarray(X, float), np.asarray(u, float)
    size = {"p3p": 3, "epnp": 6}[minimal]
    n = len(X)
    if n < size + 1:
        raise ValueError(f"pnp_ransac ({minimal}) needs at least {size + 1} correspondences, got {n}")
    x = normalise(K, u)
    rng = np.random.default_rng(seed)
    best, best_inliers, needed, drawn = None, np.zeros(n, bool), max_iterations, 0
    while drawn < needed:
        drawn += 1
        sample = rng.choice(n, size, replace=False)
        poses = p3p(X[sample], x[sample]) if minimal == "p3p" else [epnp(X[sample], x[sample])]
        for R, t in poses:
            xc = X @ R.T + t
            with np.errstate(divide="ignore", invalid="ignore"):
                error = np.sum(residuals(K, R, t, X, u) ** 2, axis=1)
            inliers = (xc[:, 2] > 0) & (error <= threshold**2)
            if inliers.sum() > best_inliers.sum():
                best, best_inliers = (R, t), inliers
                needed = iterations_needed(inliers.mean(), size, confidence, max_iterations)
    if best is None or best_inliers.sum() < size + 1:
        raise ValueError(f"pnp_ransac found no pose with {size + 1} inliers among {n} correspondences")
    R, t = best
    if best_inliers.sum() >= 6 and not planar(X[best_inliers]):
        R_all, t_all = epnp(X[best_inliers], x[best_inliers])
        if np.sum(residuals(K, R_all, t_all, X[best_inliers], u[best_inliers]) ** 2) < np.sum(
            residuals(K, R, t, X[best_inliers], u[best_inliers]) ** 2
        ):
            R, t = R_all, t_all
    rms = float(np.sqrt(np.mean(np.sum(residuals(K, R, t, X[best_inliers], u[best_inliers]) ** 2, axis=1))))
    for _ in range(5 if refine else 0):  # refine on the inliers, re-classify, until the inlier set is stable
        R, t, rms = refine_pose(K, R, t, X[best_inliers], u[best_inliers])
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.sum(residuals(K, R, t, X, u) ** 2, axis=1)
        inliers = ((X @ R[2] + t[2]) > 0) & (error <= threshold**2)
        if np.array_equal(inliers, best_inliers) or inliers.sum() < size + 1:
            break
        best_inliers = inliers
    return PnPResult(R, t, best_inliers, rms, drawn)
