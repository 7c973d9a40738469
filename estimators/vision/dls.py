"""PnP by Direct Least Squares (DLS; Hesch & Roumeliotis 2011): all stationary points of a rotation-only cost.

Model. World points p_i (n, 3), unit bearings f_i (n, 3) of the normalised image points, ``λ_i f_i = R p_i + t``
(``T_cam←world = (R, t)``). With the projector ``V_i = I − f_i f_iᵀ`` (3, 3) the object-space cost is ::

    J(R, t) = Σ_i ||V_i (R p_i + t)||²,        R p_i = A_i r,   A_i = I₃ ⊗ p_iᵀ (3, 9),   r = vec(R) (9,) row-major

Its minimum over t is linear in r: ``t = T r``, ``T = −(Σ_i V_i)⁻¹ Σ_i V_i A_i`` (3, 9), leaving ::

    J(r) = rᵀ M r,        M = Σ_i (A_i + T)ᵀ V_i (A_i + T)      (9, 9), positive semi-definite

**Cayley parameters** s (3,): ``R = C̄(s) / (1 + sᵀs)``, ``C̄ = (1 − sᵀs) I + 2 [s]× + 2 s sᵀ``; vec(C̄) = C m₂(s)
with C (9, 10) over the ten monomials m₂ of degree ≤ 2. DLS minimises the numerator ``J̄(s) = m₂ᵀ (Cᵀ M C) m₂``
(a quartic; on noise-free data it is zero at the true pose, as J is); its three partial derivatives
``∂J̄/∂s_k = 0`` are cubics F (3, 20) over the 20 monomials of degree ≤ 3 (constant tensor G (3, 10, 10, 20)
contracted with Cᵀ M C). Three generic cubics have 3³ = 27 solutions (Bézout).

**Solving** (a Macaulay matrix and an action matrix). Multiplying each cubic by the 35 monomials of degree ≤ 4 gives
A (105, 120) over the 120 monomials of degree ≤ 7 (the regularity 3 + 3 + 3 − 2 of the system, so its rank is
120 − 27 = 93). The 27 monomials ``s₁^a s₂^b s₃^c`` with a, b, c ≤ 2 span the quotient ring; the other 93 follow
from them: ``m_other = −A_other⁺ A_basis m_basis``. Multiplication by the linear form ``ℓ = s · w`` (w fixed,
generic) maps the basis to itself modulo the ideal: the action matrix ``Mℓ`` (27, 27) has the monomial vectors of the
27 solutions as eigenvectors; s is read from their entries (s₁, s₂, s₃) over the entry of 1. Real solutions are
polished by three Newton steps on ∇J̄, and the (R, t = T vec R) of the smallest J with the points in front wins.

The Cayley map cannot reach a rotation by π (s → ∞); the problem is solved for the world points rotated by
Q ∈ {I, R_x(π), R_y(π), R_z(π)} (pose ``R Qᵀ`` in that frame): for any R one of the four is at most ≈ 110° from I.
"""

from __future__ import annotations

from itertools import product

import numpy as np
from scipy.linalg import solve_triangular

__all__ = ["dls", "dls_solutions"]


def _monomials(degree: int) -> list[tuple[int, int, int]]:
    """Exponents (a, b, c) of s₁^a s₂^b s₃^c with a + b + c ≤ degree, by degree."""
    return [e for d in range(degree + 1) for e in product(range(d + 1), repeat=3) if sum(e) == d]


_M2, _M3, _M4, _M7 = _monomials(2), _monomials(3), _monomials(4), _monomials(7)
_INDEX3, _INDEX7 = {e: i for i, e in enumerate(_M3)}, {e: i for i, e in enumerate(_M7)}
_BASIS = [e for e in _M7 if max(e) <= 2]  # 27
_OTHER = [e for e in _M7 if max(e) > 2]  # 93
_COLUMNS = np.array([_INDEX7[e] for e in _OTHER + _BASIS])  # Macaulay columns reordered: the other 93, the basis 27
_POSITION = {e: i for i, e in enumerate(_OTHER + _BASIS)}
#: w of the action's linear form ℓ = w · s (fixed, generic)
_W = np.array([0.5412, -0.8317, 0.3179])


def _cayley_matrix() -> np.ndarray:
    """C (9, 10): vec(C̄(s)) (row-major) = C m₂(s)."""
    index = {e: i for i, e in enumerate(_M2)}
    unit = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
    C = np.zeros((9, 10))
    for i, j in product(range(3), repeat=2):
        row = 3 * i + j
        if i == j:  # 1 − sᵀs
            C[row, index[(0, 0, 0)]] += 1
            for e in unit:
                C[row, index[tuple(2 * np.array(e))]] -= 1
        C[row, index[tuple(np.add(unit[i], unit[j]))]] += 2  # 2 s_i s_j
        k = 3 - i - j  # [s]×: [i, j] = −ε_ijk s_k
        if i != j:
            C[row, index[unit[k]]] += -2.0 if (i, j) in ((0, 1), (1, 2), (2, 0)) else 2.0
    return C


def _gradient_tensor() -> np.ndarray:
    """G (3, 10, 10, 20): ∂(m₂,a m₂,b)/∂s_k = Σ_μ G[k, a, b, μ] m₃,μ."""
    G = np.zeros((3, 10, 10, 20))
    for a, b in product(range(10), repeat=2):
        e = np.add(_M2[a], _M2[b])
        for k in range(3):
            if e[k]:
                d = e.copy()
                d[k] -= 1
                G[k, a, b, _INDEX3[tuple(d)]] += e[k]
    return G


def _macaulay_positions() -> tuple[np.ndarray, np.ndarray]:
    """Row and column (in the reordered columns) of each (cubic k, multiplier m ∈ degree ≤ 4, monomial μ) entry."""
    rows, cols = np.zeros((3, 35, 20), int), np.zeros((3, 35, 20), int)
    for k, (j, m) in product(range(3), enumerate(_M4)):
        for mu, e in enumerate(_M3):
            rows[k, j, mu] = 35 * k + j
            cols[k, j, mu] = _POSITION[tuple(np.add(m, e))]
    return rows.reshape(3, -1), cols.reshape(3, -1)


def _action_rows() -> np.ndarray:
    """(3, 27): for each variable k and basis monomial b, the position of s_k b among (other 93 | basis 27)."""
    return np.array([[_POSITION[tuple(np.add(b, np.eye(3, dtype=int)[k]))] for b in _BASIS] for k in range(3)])


_C = _cayley_matrix()
_G = _gradient_tensor()
_ROWS, _COLS = _macaulay_positions()
_FLAT = (120 * _ROWS + _COLS).ravel()  # positions in the flattened A (105 · 120)
_ACTION = _action_rows()
_ONE, _S = _BASIS.index((0, 0, 0)), [_BASIS.index(e) for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
_E3 = np.array(_M3)  # (20, 3) exponents
_LOWERED = np.maximum(_E3[None] - np.eye(3, dtype=int)[:, None, :], 0)  # (3, 20, 3): exponents of ∂/∂s_k
_E2 = np.array(_M2)  # (10, 3)


def _cost_matrices(p: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M (9, 9) and T (3, 9) of the model above from world points p (n, 3) and unit bearings f (n, 3)."""
    n = len(p)
    V = np.eye(3) - f[:, :, None] * f[:, None, :]  # (n, 3, 3)
    A = np.zeros((n, 3, 9))
    for k in range(3):
        A[:, k, 3 * k : 3 * k + 3] = p
    T = -np.linalg.solve(V.sum(axis=0), (V @ A).sum(axis=0))
    B = A + T  # (n, 3, 9)
    return B.reshape(-1, 9).T @ (V @ B).reshape(-1, 9), T  # Σ_i B_iᵀ (V_i B_i)


def _monomial_values(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """m₃(s) (m, 20) and ∂m₃/∂s (m, 3, 20) of points s (m, 3): ∂(s^e)/∂s_k = e_k s^(e − 1_k)."""
    values = np.prod(s[:, None, :] ** _E3, axis=2)
    derivative = _E3.T * np.prod(s[:, None, None, :] ** _LOWERED, axis=3)  # (m, 3, 20)
    return values, derivative


def _stationary_points(F: np.ndarray) -> np.ndarray:
    """The real solutions s (m, 3) of the three cubics F (3, 20) (coefficients over m₃)."""
    A = np.zeros(105 * 120)
    A[_FLAT] = np.broadcast_to(F[:, None, :], (3, 35, 20)).ravel()
    A = A.reshape(105, 120)
    Q, U = np.linalg.qr(A[:, :93])  # A_other = Q U, U (93, 93) upper triangular
    other = -solve_triangular(U, Q.T @ A[:, 93:])  # (93, 27): m_other = other @ m_basis
    reduced = np.vstack([other, np.eye(27)])  # (120, 27): every monomial of degree ≤ 7 in the basis
    action = sum(_W[k] * reduced[_ACTION[k]] for k in range(3))  # (27, 27): ℓ m_basis = action m_basis
    values, vectors = np.linalg.eig(action)
    vectors = vectors / vectors[_ONE]
    real = (np.abs(values.imag) <= 1e-6 * np.maximum(1.0, np.abs(values.real))) & np.all(
        np.isfinite(vectors[_S]), axis=0
    )
    s = vectors[_S][:, real].real.T  # (m, 3)
    for _ in range(3):  # Newton on ∇J̄ = F m₃(s) = 0
        values3, derivative = _monomial_values(s)
        g = values3 @ F.T  # (m, 3)
        H = np.einsum("kc,mjc->mkj", F, derivative)  # (m, 3, 3): ∂g_k/∂s_j
        ok = np.abs(np.linalg.det(H)) > 1e-300
        s[ok] -= np.linalg.solve(H[ok], g[ok][:, :, None])[:, :, 0]
    return s


def dls_solutions(M: np.ndarray, T: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Every real stationary pose (R, t, J) of the cost rᵀ M r (M (9, 9), t = T r, T (3, 9)) in one Cayley frame."""
    F = np.einsum("ab,kabm->km", _C.T @ M @ _C, _G)
    s = _stationary_points(F)
    r = np.prod(s[:, None, :] ** _E2, axis=2) @ _C.T / (1 + np.sum(s * s, axis=1, keepdims=True))  # (m, 9): vec R
    costs = np.einsum("mi,ij,mj->m", r, M, r)
    return [(r[k].reshape(3, 3), T @ r[k], float(costs[k])) for k in range(len(s))]


_FRAMES = [np.eye(3), np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]


def dls(X: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pose (R, t) of n ≥ 4 world points X (n, 3) (planar or not) seen at normalised x (n, 2): the smallest
    object-space cost J among the stationary points with the points in front of the camera. ValueError if none."""
    X, x = np.asarray(X, float), np.asarray(x, float)
    if len(X) < 4:
        raise ValueError(f"DLS needs at least 4 points, got {len(X)}")
    f = np.column_stack([x, np.ones(len(x))])
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    M, T = _cost_matrices(X, f)
    best, best_cost = None, np.inf
    for Q in _FRAMES:  # world points Q p: R' = R Qᵀ, vec R' = P vec R with P = I₃ ⊗ Q, so M' = P M Pᵀ, T' = T Pᵀ
        P = np.kron(np.eye(3), Q)
        for R, t, cost in dls_solutions(P @ M @ P.T, T @ P.T):
            R = R @ Q
            if cost < best_cost and np.mean(np.einsum("ni,ni->n", f, X @ R.T + t) > 0) > 0.5:
                best, best_cost = (R, t), cost
    if best is None:
        raise ValueError(f"DLS found no pose with the points in front among {len(X)} points")
    return best
