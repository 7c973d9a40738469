"""Two calibrated views: the essential matrix (5-point and normalised 8-point), its four decompositions, cheirality.

Model. Camera 2 sees a point at ``x_2 = R x_1 + t`` from camera 1's coordinates (``(R, t) = T_2←1``); with
normalised homogeneous image points ``x̂_k = (x_k, y_k, 1)`` every correspondence satisfies the epipolar constraint ::

    x̂_2ᵀ E x̂_1 = 0,        E = [t]× R   (3, 3), rank 2, singular values (σ, σ, 0), defined up to scale.

Each correspondence is one linear equation ``a·vec(E) = 0`` in the row-major vec(E) (9,), a = x̂_2 ⊗ x̂_1.

**5-point** (Stewénius, Engels & Nistér 2006; Nistér 2004). Five correspondences leave a 4-dimensional null space
``E = x X + y Y + z Z + W`` (the last four right singular vectors of A (5, 9)). The cubic constraints ::

    det E = 0   (1),        2 E Eᵀ E − tr(E Eᵀ) E = 0   (9)

are 10 polynomials in (x, y, z) over the 20 monomials of degree ≤ 3, ordered
``x³ x²y xy² y³ x²z xyz y²z xz² yz² z³ | x² xy y² xz yz z² x y z 1``. Both constraints are trilinear in E, so their
coefficient matrix C (10, 20) is the fixed tensor of the constraints (10, 9, 9, 9) contracted with the null-space basis
(4, 9) three times and summed onto monomials. Gauss-Jordan elimination gives ``cubic_i = −B_i · b`` (B (10, 10)) for
the basis ``b = (x², xy, y², xz, yz, z², x, y, z, 1)``, and multiplication by x acts on b as the 10 × 10 matrix ::

    M[0:6] = −B[(x³, x²y, xy², x²z, xyz, xz²)],  M[6, 0] = M[7, 1] = M[8, 3] = M[9, 6] = 1       (M b = x b)

whose real eigenvectors v give the (up to 10) solutions (x, y, z) = v[6:9] / v[9].

**8-point** (Longuet-Higgins 1981; Hartley 1997): Hartley-normalise each image (centroid to 0, mean distance √2),
take the smallest right singular vector of A (n, 9), project onto (σ, σ, 0) and undo the normalisation.

**Decomposition** (Hartley & Zisserman 2004, §9.6.2): E = U diag(1, 1, 0) Vᵀ with det U = det V = 1, ::

    W = [[0, −1, 0], [1, 0, 0], [0, 0, 1]]:   R ∈ {U W Vᵀ, U Wᵀ Vᵀ},   t ∈ {+u₃, −u₃}      (four (R, t), ||t|| = 1)

**Cheirality**: triangulate the correspondences for each of the four (DLT, :mod:`.triangulation`) and keep the one
that puts the most points in front of both cameras (z > 0) — for a true configuration exactly one of the four does.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np

from .ransac import iterations_needed
from .triangulation import depths, triangulate_dlt

__all__ = [
    "five_point",
    "eight_point",
    "decompose_essential",
    "cheirality_counts",
    "relative_pose",
    "sampson_distance",
    "essential_ransac",
    "EssentialResult",
]


def _constraint_tensor() -> np.ndarray:
    """T (10, 9, 9, 9): constraint c of E equals Σ T[c, p, q, r] e_p e_q e_r (e = vec(E) row-major)."""
    T = np.zeros((10, 9, 9, 9))
    idx = np.arange(9).reshape(3, 3)
    for i, j, k in product(range(3), repeat=3):  # det E = Σ ε_ijk E_0i E_1j E_2k
        sign = np.linalg.det(np.eye(3)[[i, j, k]])
        if sign:
            T[0, idx[0, i], idx[1, j], idx[2, k]] += sign
    for a, b in product(range(3), repeat=2):  # (2 E Eᵀ E − tr(E Eᵀ) E)_ab
        for c, d in product(range(3), repeat=2):
            T[1 + idx[a, b], idx[a, c], idx[d, c], idx[d, b]] += 2.0
            T[1 + idx[a, b], idx[c, d], idx[c, d], idx[a, b]] -= 1.0
    return T


_MONOMIALS = [
    (3, 0, 0), (2, 1, 0), (1, 2, 0), (0, 3, 0), (2, 0, 1), (1, 1, 1), (0, 2, 1), (1, 0, 2), (0, 1, 2), (0, 0, 3),
    (2, 0, 0), (1, 1, 0), (0, 2, 0), (1, 0, 1), (0, 1, 1), (0, 0, 2), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0),
]  # fmt: skip


def _monomial_map() -> np.ndarray:
    """S (64, 20): the product m_i m_j m_k of (x, y, z, 1) factors (i, j, k) as the monomial column it lands on."""
    unit = np.vstack([np.eye(3, dtype=int), np.zeros(3, dtype=int)])
    column = {m: c for c, m in enumerate(_MONOMIALS)}
    S = np.zeros((64, 20))
    for n, (i, j, k) in enumerate(product(range(4), repeat=3)):
        S[n, column[tuple(unit[i] + unit[j] + unit[k])]] = 1.0
    return S


_T = _constraint_tensor()
_S = _monomial_map()
#: the rows of x · (x², xy, y², xz, yz, z²) among the leading cubic monomials
_ACTION_ROWS = [0, 1, 2, 4, 5, 7]


def _homogeneous(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float).reshape(-1, 2)
    return np.column_stack([x, np.ones(len(x))])


def _epipolar_rows(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """A (n, 9): row i is x̂_2 ⊗ x̂_1, so that A vec(E) = (x̂_2ᵀ E x̂_1)_i."""
    h1, h2 = _homogeneous(x1), _homogeneous(x2)
    return (h2[:, :, None] * h1[:, None, :]).reshape(-1, 9)


def five_point(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """Essential matrices (m, 3, 3), m ≤ 10, ||E||_F = 1, from five (or more: least squares) normalised
    correspondences x1, x2 (n, 2), n ≥ 5."""
    if len(x1) < 5:
        raise ValueError(f"the 5-point algorithm needs at least 5 correspondences, got {len(x1)}")
    A = _epipolar_rows(x1, x2)
    N = np.linalg.svd(A, full_matrices=len(A) < 9)[2][-4:]  # rows X, Y, Z, W: E = xX + yY + zZ + W
    C = np.tensordot(_T, N, axes=([3], [1]))  # (10, 9, 9, 4)
    C = np.tensordot(C, N, axes=([2], [1]))  # (10, 9, 4, 4)
    C = np.tensordot(C, N, axes=([1], [1]))  # (10, 4, 4, 4): the factors' order is immaterial to the monomial
    A = C.reshape(10, 64) @ _S  # (10, 20)
    try:
        B = np.linalg.solve(A[:, :10], A[:, 10:])
    except np.linalg.LinAlgError:
        return np.zeros((0, 3, 3))
    M = np.zeros((10, 10))
    M[:6] = -B[_ACTION_ROWS]
    M[6, 0] = M[7, 1] = M[8, 3] = M[9, 6] = 1.0
    values, vectors = np.linalg.eig(M)
    real = np.abs(values.imag) <= 1e-8 * np.maximum(1.0, np.abs(values.real))
    v = vectors[:, real].real
    v = v[:, np.abs(v[9]) > 1e-12]
    xyz = (v[6:9] / v[9]).T  # (m, 3)
    E = xyz @ N[:3] + N[3]
    E /= np.linalg.norm(E, axis=1, keepdims=True)
    return E.reshape(-1, 3, 3)


def _hartley(x: np.ndarray) -> np.ndarray:
    """The similarity T (3, 3) moving points x (n, 2) to centroid 0 and mean distance √2."""
    mu = x.mean(axis=0)
    scale = np.sqrt(2) / np.mean(np.linalg.norm(x - mu, axis=1))
    return np.array([[scale, 0, -scale * mu[0]], [0, scale, -scale * mu[1]], [0, 0, 1]])


def eight_point(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """The essential matrix (3, 3), ||E||_F = 1, of n ≥ 8 normalised correspondences (normalised 8-point)."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    if len(x1) < 8:
        raise ValueError(f"the 8-point algorithm needs at least 8 correspondences, got {len(x1)}")
    T1, T2 = _hartley(x1), _hartley(x2)
    y1, y2 = (_homogeneous(x1) @ T1.T)[:, :2], (_homogeneous(x2) @ T2.T)[:, :2]
    A = _epipolar_rows(y1, y2)
    F = np.linalg.svd(A, full_matrices=len(A) < 9)[2][-1].reshape(3, 3)
    E = T2.T @ F @ T1
    U, s, Vt = np.linalg.svd(E)
    E = U @ np.diag([1.0, 1.0, 0.0]) @ Vt
    return E / np.linalg.norm(E)


def decompose_essential(E: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The four (R, t) (||t|| = 1) whose [t]× R is proportional to E."""
    U, _, Vt = np.linalg.svd(E)
    U = U * np.sign(np.linalg.det(U))
    Vt = Vt * np.sign(np.linalg.det(Vt))
    W = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    t = U[:, 2]
    return [(U @ W @ Vt, t), (U @ W @ Vt, -t), (U @ W.T @ Vt, t), (U @ W.T @ Vt, -t)]


def cheirality_counts(x1: np.ndarray, x2: np.ndarray, candidates) -> np.ndarray:
    """For each (R, t) of ``candidates``: how many correspondences triangulate in front of both cameras."""
    identity = (np.eye(3), np.zeros(3))
    counts = []
    for R, t in candidates:
        X = triangulate_dlt(x1, x2, identity, (R, t))
        with np.errstate(invalid="ignore"):
            counts.append(int(np.sum((depths(X, identity) > 0) & (depths(X, (R, t)) > 0))))
    return np.array(counts)


def _paired_cheirality_counts(x1: np.ndarray, x2: np.ndarray, candidates) -> np.ndarray:
    """:func:`cheirality_counts` of the four decompositions ((R_a, ±t), (R_b, ±t)) with two triangulations: the
    DLT rows of camera 2 are linear in (t, w), so (R, −t) has the solution (X, −w) of (R, t) — the same points
    mirrored through camera 1, both depths negated."""
    identity = (np.eye(3), np.zeros(3))
    counts = []
    for R, t in candidates[0::2]:
        X = triangulate_dlt(x1, x2, identity, (R, t))
        with np.errstate(invalid="ignore"):
            z1, z2 = depths(X, identity), depths(X, (R, t))
        counts += [int(np.sum((z1 > 0) & (z2 > 0))), int(np.sum((z1 < 0) & (z2 < 0)))]
    return np.array(counts)


def relative_pose(E: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The (R, t, points in front) of the decomposition of E that passes the cheirality check best."""
    candidates = decompose_essential(E)
    counts = _paired_cheirality_counts(x1, x2, candidates)
    best = int(np.argmax(counts))
    return candidates[best][0], candidates[best][1], int(counts[best])


def sampson_distance(E: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """First-order geometric error (n,) of each correspondence (normalised units, squared)::

    d² = (x̂_2ᵀ E x̂_1)² / ((E x̂_1)₁² + (E x̂_1)₂² + (Eᵀ x̂_2)₁² + (Eᵀ x̂_2)₂²)
    """
    return _sampson(E, _homogeneous(x1), _homogeneous(x2))


def _sampson(E: np.ndarray, h1: np.ndarray, h2: np.ndarray) -> np.ndarray:
    """:func:`sampson_distance` of homogeneous points h1, h2 (n, 3)."""
    Ex1, Etx2 = h1 @ E.T, h2 @ E
    num = np.einsum("ij,ij->i", h2, Ex1) ** 2
    return num / (Ex1[:, 0] ** 2 + Ex1[:, 1] ** 2 + Etx2[:, 0] ** 2 + Etx2[:, 1] ** 2)


def _sampson_all(Es: np.ndarray, h1: np.ndarray, h2: np.ndarray) -> np.ndarray:
    """:func:`_sampson` of several E (m, 3, 3) at once: (m, n)."""
    Ex1, Etx2 = Es @ h1.T, np.swapaxes(Es, 1, 2) @ h2.T  # (m, 3, n)
    num = np.sum(h2.T * Ex1, axis=1) ** 2
    return num / (Ex1[:, 0] ** 2 + Ex1[:, 1] ** 2 + Etx2[:, 0] ** 2 + Etx2[:, 1] ** 2)


@dataclass(frozen=True)
class EssentialResult:
    """E (3, 3), the relative pose (R, t) = T_2←1 (||t|| = 1), the inlier mask (n,) and the samples drawn."""

    E: np.ndarray
    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    iterations: int


def essential_ransac(
    x1: np.ndarray,
    x2: np.ndarray,
    threshold: float,
    confidence: float = 0.999,
    max_iterations: int = 1000,
    seed: int = 0,
) -> EssentialResult:
    """E by the 5-point algorithm inside RANSAC (Sampson distance ≤ ``threshold`` [normalised units]; adaptive
    number of samples), then re-estimated on the inliers (least-squares 5-point null space, root closest to the
    RANSAC model) and decomposed with the cheirality check. Fewer than 5 correspondences or no model: ValueError."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    n = len(x1)
    if n < 5:
        raise ValueError(f"essential_ransac needs at least 5 correspondences, got {n}")
    rng = np.random.default_rng(seed)
    h1, h2 = _homogeneous(x1), _homogeneous(x2)
    best_E, best_inliers, needed, drawn = None, np.zeros(n, bool), max_iterations, 0
    while drawn < needed:
        drawn += 1
        sample = rng.choice(n, 5, replace=False)
        Es = five_point(x1[sample], x2[sample])
        if not len(Es):
            continue
        inliers = _sampson_all(Es, h1, h2) <= threshold**2  # (m, n), all the sample's solutions at once
        counts = inliers.sum(axis=1)
        k = int(np.argmax(counts))
        if counts[k] > best_inliers.sum():
            best_E, best_inliers = Es[k], inliers[k]
            needed = iterations_needed(inliers[k].mean(), 5, confidence, max_iterations)
    if best_E is None:
        raise ValueError("essential_ransac found no essential matrix")
    refined = five_point(x1[best_inliers], x2[best_inliers])
    if len(refined):
        scores = [np.sum(_sampson(E, h1, h2) <= threshold**2) for E in refined]
        E = refined[int(np.argmax(scores))]
        if max(scores) >= best_inliers.sum():
            best_E, best_inliers = E, _sampson(E, h1, h2) <= threshold**2
    R, t, _ = relative_pose(best_E, x1[best_inliers], x2[best_inliers])
    return EssentialResult(best_E, R, t, best_inliers, drawn)
