"""The inner loops of EKF-SLAM: the O(N²) covariance update (numba, or BLAS in place) and the robot-block chain.

``update_lower(buffer, n, Cᵀ, s)`` applies ``P ← P + C diag(s) Cᵀ`` (C n × d) to the lower triangle
(i ≥ j) of the live block ``P = buffer[:n, :n]`` of a C-contiguous buffer, in place — the half of
P that is the covariance's storage (:mod:`.storage`; the upper triangle is copied from it by
:func:`mirror_lower` only when the whole matrix is read):

* d ≤ ``_FUSED_MAX`` (one observation): a fused numba loop, element (i, j ≤ i) receives
  ``Σ_k (C_ik C_jk) s_k`` in one row-major pass over the lower triangle (memory-bound,
  vectorised by LLVM);
* larger d (a deferred or batched update of a whole observation set, d = 2m … 6m): BLAS —
  ``dsyrk`` (``P + α C Cᵀ``) when every s_k is the same α, else ``dsyr2k`` with ``A = C``,
  ``B = C diag(s)``, ``α = ½`` (``½ (A Bᵀ + B Aᵀ) = C diag(s) Cᵀ``) — called from compiled code through
  ``scipy.linalg.cython_blas`` (no per-call Python or ctypes work) so that it works on the strided live block and factor (leading
  dimensions = their row strides) without a copy. At d ≈ 20 the product is compute-bound (O(d N²/2) flops), where the fused loop
  would be several times slower.

``mirror_lower(buffer, n)`` copies the strict lower triangle to the upper one in 8 × 8 tiles
(each written cache line is filled by one tile row), which makes P bitwise symmetric;
``add_term_upper(buffer, n, Ut, Ust, r, off)`` adds the pending term to the O(N) upper entries a filter step reads
(the robot rows, from contiguous rows of U, and each landmark block's ``P[s, s + 1]``) instead of copying them from
the lower triangle, which would touch one cache line per row.
``apply_term(…)`` applies a pending term in one call (:func:`update_lower`, :func:`add_term_upper`, the cached checked entries)
and clears it; ``gather_columns(buffer, n, cols)`` reads columns of P from what is current in the stored lower triangle and
robot rows (a new landmark's read of the robot rows).

The update of one observation set runs in the layout of its rows: ``HP = (PHᵀ)ᵀ`` (d × N) and the factor ``Cᵀ``
(c × N), so every O(N) loop runs along a contiguous row.

``gain_terms(HP, S, L, ν, joseph, Cᵀ)`` is the O(N d) part of one update (the formulas are stated where it is used,
``filter.py``'s ``_correct``): from HP, the innovation covariance S (d × d), its Cholesky factor L and ν, the NIS
``νᵀ S⁻¹ ν``, the state step ``K ν`` and the symmetric terms ``C diag(s) Cᵀ`` of the covariance update (Cᵀ written
into the given rows).

``innovation_one(P, n, Ut, Ust, r, s, x̆_r, m̆, x, z, R)`` is the O(N r) part of one observation of the landmark at
entries (s, s + 1): ``H`` (2 × 5) at the linearisation point (x̆_r, m̆), ``HP = H P[idx, :]`` read from the
current P (the stored lower triangle and the pending term ``Ustᵀ Ut``, :mod:`.storage`), ``S = H HP[:, idx]ᵀ + R``
and ``ν = z − h(x_r, m)`` at the current estimate. ``correct(…)`` is the rest, shared with the batch form: the
Cholesky factor of S, :func:`gain_terms`, the entries of the update term (:func:`.checks.low_rank_entries`), the
checks of the entries P would have (:func:`.checks.entries_failure`) and, only if all pass, the commit — x += K ν,
the term appended to the pending one. ``correct_run(…)`` applies a run of consecutive matched observations of a set
in one compiled call, stopping at the first that is not applied: in the standard form in the span of the rows'
``B_j = H_j P_0`` (``_projected_run``: one read of P per row, the small 2k × 2k algebra of the sequential update, and
at the end the term's rows ``Uᵀ = Tᵀ B`` by one BLAS product and one check of the entries P will have), else — the
Joseph form, or a run whose end check fails, to find the row that fails — row by row (``_rows_run``: ``innovation_one``,
which reads the pending term, then ``correct``), so a set of m known landmarks costs O(N m) reads plus an O(N m²)
product (row by row: O(N m r)) and one call. ``batch_innovation(…)`` is the batch form's
counterpart of ``innovation_one``: the m observations' HP rows (2m × N) from the same current P, the 2m × 2m S with its
cross terms, and ν, in one call.

The prediction: ``chain_geometry(x0, δ, lin, Q)`` composes a chain of K body increments (the poses, the world-frame
displacements D_k at the linearisation poses and the noise rotated to the world frame, one pass);
``robot_chain(P0, D, Q)`` runs the 3 × 3 robot-block recursion ``P_{k+1} = G_k P_k G_kᵀ + Q_k`` with
``G_k = I + [[0, 0, −D_k,y], [0, 0, D_k,x], [0, 0, 0]]`` and returns every P_k (K, 3, 3); ``semidefinite(covs)``
checks them; ``cross_covariances(P, n, ΣD)`` forms ``Φ P_rm`` from the robot rows and ``set_robot_block`` writes the
robot block, rows and columns; ``predict_chain(…)`` is all of it in one call, checked before it commits.
"""

from __future__ import annotations

import numpy as np
from llvmlite import binding
from numba import njit, types
from numba.extending import get_cython_function_address

from ..kernels import range_bearing, wrap
from .checks import OK, entries_failure, low_rank_entries

__all__ = [
    "update_lower",
    "mirror_lower",
    "add_term_upper",
    "apply_term",
    "gather_columns",
    "gain_terms",
    "innovation_one",
    "batch_innovation",
    "correct",
    "correct_run",
    "chain_geometry",
    "robot_chain",
    "semidefinite",
    "cross_covariances",
    "set_robot_block",
    "predict_chain",
    "APPLIED",
    "S_INDEFINITE",
    "NOT_FINITE",
    "ROBOT_INDEFINITE",
]

#: largest d handled by the fused loop (above it BLAS is faster)
_FUSED_MAX = 4
#: columns per block of :func:`add_term_upper`'s sums
_ROW_BLOCK = 512


def _blas(name: str, arguments: int) -> types.ExternalFunction:
    """A Fortran BLAS routine of scipy.linalg.cython_blas (every argument a pointer), callable from compiled code: its
    address is registered under a symbol of this module's own, so the kernels that call it are cached like any other."""
    symbol = f"slamarena_ekf_slam_{name}"
    binding.add_symbol(symbol, get_cython_function_address("scipy.linalg.cython_blas", name))
    return types.ExternalFunction(symbol, types.void(*[types.voidptr] * arguments))


# Fortran BLAS: (uplo, trans, n, k, alpha, a, lda, [b, ldb,] beta, c, ldc)
_dsyrk = _blas("dsyrk", 10)
_dsyr2k = _blas("dsyr2k", 12)
# (transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc) and (trans, m, n, alpha, a, lda, x, incx, beta, y, incy)
_dgemm = _blas("dgemm", 13)
_dgemv = _blas("dgemv", 11)


@njit(cache=True)
def _fused(P, n, Ct, s):
    d = Ct.shape[0]
    for i in range(n):
        row = P[i]
        for k in range(d):
            a = Ct[k, i]
            c = Ct[k]
            sk = s[k]
            for j in range(i + 1):
                row[j] += (a * c[j]) * sk


@njit(cache=True)
def mirror_lower(P, n):
    """P[j, i] = P[i, j] for j < i < n: the strict lower triangle copied to the upper one, in 8 × 8 tiles."""
    for i0 in range(0, n, 8):
        i1 = min(i0 + 8, n)
        for j0 in range(0, i0, 8):
            for j in range(j0, j0 + 8):
                for i in range(i0, i1):
                    P[j, i] = P[i, j]
        for i in range(i0, i1):
            for j in range(i0, i):
                P[j, i] = P[i, j]


@njit(cache=True)
def add_term_upper(P, n, Ut, Ust, r, off):
    """The term ``Ustᵀ Ut`` (rank r) added to the O(N) upper entries a filter step reads, which :func:`update_lower` does
    not write: the robot rows P[a, i] (a < 3, i > a), ``Σ_k Ust[k, a] Ut[k, i]``, and each landmark block's P[s, s + 1],
    whose term is ``off`` (the pending entries, :func:`.checks.low_rank_entries`).

    The robot rows are summed in blocks of ``_ROW_BLOCK`` columns: the three sums of a block stay in cache while the r
    rows of U stream through it, and each entry of P is written once (not once per term)."""
    acc = np.empty((3, _ROW_BLOCK))
    for i0 in range(0, n, _ROW_BLOCK):
        i1 = min(i0 + _ROW_BLOCK, n)
        m = i1 - i0
        a0, a1, a2 = acc[0, :m], acc[1, :m], acc[2, :m]
        a0[:], a1[:], a2[:] = 0.0, 0.0, 0.0
        for k in range(r):
            u = Ut[k, i0:i1]
            w0, w1, w2 = Ust[k, 0], Ust[k, 1], Ust[k, 2]
            for i in range(m):
                a0[i] += w0 * u[i]
                a1[i] += w1 * u[i]
                a2[i] += w2 * u[i]
        for a in range(3):
            row = P[a]
            for i in range(max(i0, a + 1), i1):
                row[i] += acc[a, i - i0]
    for j in range((n - 3) // 2):
        P[3 + 2 * j, 4 + 2 * j] += off[j]


@njit(cache=True)
def update_lower(buffer, n, Ct, s):
    """The lower triangle of buffer[:n, :n] += C diag(s) Cᵀ in place; buffer C-contiguous, Ct = Cᵀ (d × n, rows contiguous), s (d,)."""
    if buffer.strides[1] != 8 or buffer.strides[0] != 8 * buffer.shape[1] or Ct.strides[1] != 8:
        raise ValueError("update_lower needs a C-contiguous buffer and a Cᵀ with contiguous rows")
    d = Ct.shape[0]
    if d == 0 or n == 0:
        return
    if d <= _FUSED_MAX:
        _fused(buffer, n, Ct, s)
        return
    # The C-ordered buffer read as a Fortran matrix (leading dimension = its row length) is Pᵀ = P, and
    # Fortran "U" is its C-ordered lower triangle; the C-ordered d × n Cᵀ is the Fortran n × d C
    # (leading dimension = its row stride), so trans="N" forms C Cᵀ.
    ints = np.array([n, d, buffer.shape[1], Ct.strides[0] // 8, n], dtype=np.int32)  # n, k, ldc, lda, ldb
    flags = np.array([85, 78], dtype=np.uint8)  # uplo "U", trans "N"
    scalars = np.array([s[0], 1.0])  # α, β
    if np.all(s == s[0]):
        _dsyrk(
            flags.ctypes,
            flags[1:].ctypes,
            ints.ctypes,
            ints[1:].ctypes,
            scalars.ctypes,
            Ct.ctypes,
            ints[3:].ctypes,
            scalars[1:].ctypes,
            buffer.ctypes,
            ints[2:].ctypes,
        )
    else:  # ½ (C Bᵀ + B Cᵀ) with B = C diag(s)
        B = np.empty((d, n))
        for k in range(d):
            B[k] = Ct[k, :n] * s[k]
        scalars[0] = 0.5
        _dsyr2k(
            flags.ctypes,
            flags[1:].ctypes,
            ints.ctypes,
            ints[1:].ctypes,
            scalars.ctypes,
            Ct.ctypes,
            ints[3:].ctypes,
            B.ctypes,
            ints[4:].ctypes,
            scalars[1:].ctypes,
            buffer.ctypes,
            ints[2:].ctypes,
        )


@njit(cache=True)
def apply_term(P, n, Ut, Ust, sg, r, pend, stored, stored_valid):
    """Apply the pending term ``Ustᵀ Ut`` (rank r) to the lower triangle (:func:`update_lower`) and to the upper entries a
    step reads (:func:`add_term_upper`), add its checked entries ``pend`` to the cached ones of the stored P ``stored``
    (if valid), and clear it."""
    update_lower(P, n, Ut[:r, :n], sg[:r])
    add_term_upper(P, n, Ut, Ust, r, pend[2])
    if stored_valid:
        stored[0][:] += pend[0]
        stored[1][:] += pend[1]
        stored[2][:] += pend[2]
    pend[0][:] = 0.0
    pend[1][:] = 0.0
    pend[2][:] = 0.0


@njit(cache=True)
def gather_columns(P, n, cols):
    """``P[:n, c]`` for each c of cols (k,) from what is current in the stored P: a robot column (c < 3) is a robot row; a
    landmark column is its row of the lower triangle left of the diagonal and its column from the diagonal down."""
    out = np.empty((n, cols.size))
    for k in range(cols.size):
        c = cols[k]
        if c < 3:
            for i in range(n):
                out[i, k] = P[c, i]
            continue
        for i in range(c):
            out[i, k] = P[c, i]
        for i in range(c, n):
            out[i, k] = P[i, c]
    return out


@njit(cache=True)
def _lower_inverse(L):
    """L⁻¹ of a d × d lower-triangular L with a positive diagonal (forward substitution)."""
    d = L.shape[0]
    Li = np.zeros((d, d))
    for j in range(d):
        Li[j, j] = 1.0 / L[j, j]
        for i in range(j + 1, d):
            acc = 0.0
            for k in range(j, i):
                acc -= L[i, k] * Li[k, j]
            Li[i, j] = acc / L[i, i]
    return Li


@njit(cache=True)
def gain_terms(HP, S, L, nu, joseph, Ct):
    """(νᵀ S⁻¹ ν, K ν, s) with S = L Lᵀ, writing the update's factor Cᵀ into rows 0 … c − 1 of Ct (columns 0 … N − 1).

    HP = (PHᵀ)ᵀ (d, N). Wᵀ = L⁻¹ HP, Kᵀ = L⁻ᵀ Wᵀ; standard: C = W, s = −1; Joseph: C = [W, K + D, K − D],
    s = [−1, ½, −½], Dᵀ = S Kᵀ − HP. Every loop runs along the N columns of a row (contiguous, vectorised).
    """
    d, N = HP.shape
    Linv = _lower_inverse(L)
    e = Linv @ nu  # L⁻¹ ν: NIS = eᵀe
    Sinv_nu = Linv.T @ e  # S⁻¹ ν
    dx = np.zeros(N)
    for a in range(d):  # K ν = PHᵀ S⁻¹ ν
        w = Sinv_nu[a]
        h = HP[a]
        for i in range(N):
            dx[i] += h[i] * w
    for a in range(d):  # Wᵀ = L⁻¹ HP (L⁻¹ lower triangular)
        row = Ct[a]
        for i in range(N):
            row[i] = 0.0
        for b in range(a + 1):
            w = Linv[a, b]
            h = HP[b]
            for i in range(N):
                row[i] += w * h[i]
    c = 3 * d if joseph else d
    s = np.empty(c)
    s[:d] = -1.0
    if joseph:
        s[d : 2 * d], s[2 * d :] = 0.5, -0.5
        Kt = np.zeros((d, N))
        for a in range(d):  # Kᵀ = L⁻ᵀ Wᵀ ((L⁻ᵀ)[a, b] = L⁻¹[b, a], zero for b < a)
            for b in range(a, d):
                w = Linv[b, a]
                for i in range(N):
                    Kt[a, i] += w * Ct[b, i]
        for a in range(d):  # Dᵀ = S Kᵀ − HP; rows K + D and K − D
            plus, minus = Ct[d + a], Ct[2 * d + a]
            for i in range(N):
                acc = -HP[a, i]
                for b in range(d):
                    acc += S[a, b] * Kt[b, i]
                plus[i] = Kt[a, i] + acc
                minus[i] = Kt[a, i] - acc
    return e @ e, dx, s


@njit(cache=True)
def _hp_one(P, n, Ut, Ust, r, s, H, HP):
    """HP (2, n) ← H P[idx, :] for H (2, 5) on the entries idx = (0, 1, 2, s, s + 1), read from the current P (the stored
    lower triangle and robot rows, and the pending term ``Ustᵀ Ut`` of rank r)."""
    h, hb = HP[0], HP[1]
    a0, a1, a2, a3, a4 = H[0, 0], H[0, 1], H[0, 2], H[0, 3], H[0, 4]
    b0, b1, b2, b3, b4 = H[1, 0], H[1, 1], H[1, 2], H[1, 3], H[1, 4]
    p0, p1, p2 = P[0], P[1], P[2]  # the robot rows are current
    for i in range(n):
        h[i] = a0 * p0[i] + a1 * p1[i] + a2 * p2[i]
        hb[i] = b0 * p0[i] + b1 * p1[i] + b2 * p2[i]
    q0, q1 = P[s], P[s + 1]  # left of the block: rows s, s + 1 of the lower triangle
    for i in range(s):
        h[i] += a3 * q0[i] + a4 * q1[i]
        hb[i] += b3 * q0[i] + b4 * q1[i]
    h[s] += a3 * P[s, s] + a4 * P[s + 1, s]
    hb[s] += b3 * P[s, s] + b4 * P[s + 1, s]
    for i in range(s + 1, n):  # at and below row s + 1: columns s, s + 1 of the lower triangle
        c0, c1 = P[i, s], P[i, s + 1]
        h[i] += a3 * c0 + a4 * c1
        hb[i] += b3 * c0 + b4 * c1
    # the pending term: H P[idx, :] += (H Ut[:, idx]ᵀ) Ust, its r rows read once each, two at a time
    g = np.zeros((2, r))
    for k in range(r):
        g[0, k] = Ut[k, 0] * a0 + Ut[k, 1] * a1 + Ut[k, 2] * a2 + Ut[k, s] * a3 + Ut[k, s + 1] * a4
        g[1, k] = Ut[k, 0] * b0 + Ut[k, 1] * b1 + Ut[k, 2] * b2 + Ut[k, s] * b3 + Ut[k, s + 1] * b4
    for k in range(0, r - 1, 2):
        u, v = Ust[k], Ust[k + 1]
        g0, g1, e0, e1 = g[0, k], g[0, k + 1], g[1, k], g[1, k + 1]
        for i in range(n):
            h[i] += u[i] * g0 + v[i] * g1
            hb[i] += u[i] * e0 + v[i] * e1
    if r % 2:
        u = Ust[r - 1]
        g0, e0 = g[0, r - 1], g[1, r - 1]
        for i in range(n):
            h[i] += u[i] * g0
            hb[i] += u[i] * e0


@njit(cache=True)
def _jacobian(xl, ml, zhat, Hx, Hm, H):
    """H = [H_x, H_m] (2, 5) of the range-bearing model at (x̆_r, m̆)."""
    range_bearing(xl, ml, zhat, Hx, Hm)
    H[:, :3], H[:, 3:] = Hx, Hm


@njit(cache=True)
def _innovation(x, s, z, zhat, Hx, Hm):
    """ν = z − h(x_r, m) (2,) at the current estimate, the bearing wrapped."""
    range_bearing(x[:3], x[s : s + 2], zhat, Hx, Hm)
    return np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])


@njit(cache=True)
def innovation_one(P, n, Ut, Ust, r, s, xl, ml, x, z, R):
    """(HP (2, n) = (PHᵀ)ᵀ, S (2, 2), ν (2,), H (2, 5)) of one range-bearing observation z of the landmark at entries s, s + 1."""
    zhat, Hx, Hm = np.empty(2), np.empty((2, 3)), np.empty((2, 2))
    H = np.empty((2, 5))
    _jacobian(xl, ml, zhat, Hx, Hm, H)  # H = [H_x, H_m] at the linearisation point
    HP = np.empty((2, n))
    _hp_one(P, n, Ut, Ust, r, s, H, HP)
    idx = np.array([0, 1, 2, s, s + 1])
    S = np.empty((2, 2))
    for a in range(2):
        for b in range(2):
            acc = 0.0
            for c in range(5):
                acc += H[a, c] * HP[b, idx[c]]
            S[a, b] = acc
    S[0, 1] = S[1, 0] = 0.5 * (S[0, 1] + S[1, 0])
    S += R
    return HP, S, _innovation(x, s, z, zhat, Hx, Hm), H


@njit(cache=True)
def batch_innovation(P, n, Ut, Ust, r, entries, XL, ML, current, x, Z, R):
    """(HP (2m, n), S (2m, 2m), ν (2m,)) of m range-bearing observations Z (m, 2) (noise R (m, 2, 2)) of the landmarks at
    entries (e_j, e_j + 1) (m,), stacked: H_j at (XL[j], ML[j]) or at the current estimate if ``current``; HP rows 2j, 2j + 1
    = H_j P (:func:`_hp_one`, the current P), ``S[2j + a, 2k + b] = Σ_c HP[2j + a, idx_k[c]] H_k[b, c]``, symmetrised, plus
    blockdiag(R_1 … R_m); ν_j = z_j − h(x_r, m_j)."""
    m = entries.size
    zhat, Hx, Hm = np.empty(2), np.empty((2, 3)), np.empty((2, 2))
    Hs = np.empty((m, 2, 5))
    HP = np.empty((2 * m, n))
    nu = np.empty(2 * m)
    for j in range(m):
        e = entries[j]
        if current:
            _jacobian(x[:3].copy(), x[e : e + 2].copy(), zhat, Hx, Hm, Hs[j])
        else:
            _jacobian(XL[j], ML[j], zhat, Hx, Hm, Hs[j])
        _hp_one(P, n, Ut, Ust, r, e, Hs[j], HP[2 * j : 2 * j + 2])
        nu[2 * j : 2 * j + 2] = _innovation(x, e, Z[j], zhat, Hx, Hm)
    S = np.empty((2 * m, 2 * m))
    for k in range(m):
        e = entries[k]
        for b in range(2):
            H = Hs[k, b]
            for a in range(2 * m):
                row = HP[a]
                S[a, 2 * k + b] = row[0] * H[0] + row[1] * H[1] + row[2] * H[2] + row[e] * H[3] + row[e + 1] * H[4]
    for a in range(2 * m):
        for b in range(a):
            S[a, b] = S[b, a] = 0.5 * (S[a, b] + S[b, a])
    for j in range(m):
        for a in range(2):
            for b in range(2):
                S[2 * j + a, 2 * j + b] += R[j, a, b]
    return HP, S, nu


#: outcomes of :func:`correct` (a positive value: the failed covariance check, :data:`.checks.NEGATIVE_DIAGONAL` …) and
#: of :func:`predict_chain`
APPLIED, S_INDEFINITE, NOT_FINITE, ROBOT_INDEFINITE = 0, -1, -2, -3


@njit(cache=True)
def _cholesky(S):
    """Lower Cholesky factor of the d × d S and whether it exists (every pivot finite and > 0)."""
    d = S.shape[0]
    L = np.zeros((d, d))
    for j in range(d):
        acc = S[j, j]
        for k in range(j):
            acc -= L[j, k] * L[j, k]
        if not (acc > 0.0 and np.isfinite(acc)):
            return L, False
        L[j, j] = np.sqrt(acc)
        for i in range(j + 1, d):
            acc = S[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / L[j, j]
    return L, True


@njit(cache=True)
def correct(HP, S, nu, joseph, x, Ut, Ust, sg, r, pend, stored, n_robot):
    """Check and, if every check passes, commit one update (``filter.py``'s ``_correct`` states the formulas).

    The update's factor Cᵀ is computed into rows r … r + c of Ut (scratch until committed); on commit x (N,) is changed
    in place, Ust = (C diag(s))ᵀ and sg = s written to the same rows, and the term's entries added to the pending ones
    ``pend`` (diagonal (≥N,), robot block, landmark off-diagonals); ``stored``: the entries of the stored P. Returns
    (outcome, NIS, k, value): :data:`APPLIED`, :data:`S_INDEFINITE`, :data:`NOT_FINITE`, or the code of the failed check
    with its index and value (:func:`.checks.entries_failure`).
    """
    L, ok = _cholesky(S)
    if not ok:
        return S_INDEFINITE, np.nan, 0, 0.0
    N = HP.shape[1]
    c = 3 * nu.size if joseph else nu.size
    Ct = Ut[r : r + c]
    nis, dx, s = gain_terms(HP, S, L, nu, joseph, Ct)
    if not (np.isfinite(nis) and np.all(np.isfinite(dx)) and np.all(np.isfinite(Ct[:, :N]))):
        return NOT_FINITE, nis, 0, 0.0
    td, tr, to = low_rank_entries(Ct, s, N, n_robot)
    pd, pr, po = pend
    sd, sr, so = stored
    m = to.size
    code, k, value = entries_failure((sd[:N], pd[:N], td), (sr, pr, tr), (so[:m], po[:m], to), n_robot)
    if code != OK:
        return code, nis, k, value
    x += dx
    x[2] = wrap(x[2])
    for j in range(c):
        sg[r + j] = s[j]
        u, us, sj = Ut[r + j], Ust[r + j], s[j]
        for i in range(N):
            us[i] = u[i] * sj
    pd[:N] += td
    pr += tr
    po[:m] += to
    return APPLIED, nis, 0, 0.0


@njit(cache=True)
def _rows_run(P, n, Ut, Ust, sg, r, pend, stored, x, slots, XL, ML, current, Z, R, joseph, n_robot):
    """:func:`correct_run` row by row: :func:`innovation_one` then :func:`correct` for each row, in order."""
    nis = np.empty(slots.size)
    Hs = np.empty((slots.size, 2, 5))
    for j in range(slots.size):
        e = n_robot + 2 * slots[j]
        if current:
            xl, ml = x[:3].copy(), x[e : e + 2].copy()
        else:
            xl, ml = XL[j], ML[j]
        HP, S, nu, Hs[j] = innovation_one(P, n, Ut, Ust, r, e, xl, ml, x, Z[j], R[j])
        outcome, nis[j], k, value = correct(HP, S, nu, joseph, x, Ut, Ust, sg, r, pend, stored, n_robot)
        if outcome != APPLIED:
            return j, r, outcome, k, value, nis[:j], Hs[:j], S
        r += 3 * nu.size if joseph else nu.size
    return slots.size, r, APPLIED, 0, 0.0, nis, Hs, np.zeros((2, 2))


@njit(cache=True)
def _projected_run(P, n, Ut, Ust, sg, r, pend, stored, x, slots, XL, ML, current, Z, R, n_robot):
    """:func:`correct_run` in the span of the rows' ``B_j = H_j P_0`` (standard form; P_0 the current P at the call).

    With ``B`` the stacked B_i of the rows before j (2j, N), ``P_{j−1} = P_0 − Bᵀ M B`` for a symmetric M (2j, 2j), so
    row j needs only the 5 entries idx_j of each B_i:

        G = B[:, idx_j] H_jᵀ (2j, 2),   S_j = B_j[:, idx_j] H_jᵀ − Gᵀ M G + R_j,   S_j = L Lᵀ
        H_j P_{j−1} = [−Gᵀ M, I₂] [B; B_j],   W_j = [B; B_j]ᵀ t_j,   t_j = [−M G; I₂] L⁻ᵀ (2j + 2, 2)
        M ← M + t_j t_jᵀ,   x_j = x_0 + [B; B_j]ᵀ v,   v ← v + t_j L⁻¹ ν_j

    and x_{j−1} at idx_j (where h and, for ``current``, H_j are evaluated) is x_0[idx_j] + B[:, idx_j]ᵀ v. The N-long work
    is one read of P_0 per row (B_j) and, at the end, ``Uᵀ = Tᵀ B`` (T = [t_1 … t_q], one matrix product), ``dx = Bᵀ v``
    and the term's checked entries, where the row-by-row form reads the whole pending term and makes some twenty passes
    over N-vectors per row. The covariance checks are made once, on the entries of P_q: every P_j = P_q + Σ_{i>j} W_i W_iᵀ
    has them at least as large (diagonal) and its blocks differ from P_q's by positive semi-definite ones, so if P_q
    passes, every P_j does. Returns :func:`correct_run`'s tuple and whether the end's checks passed; if they did not,
    nothing was changed (the caller runs the rows one by one to find the row that fails). B is written to rows r … r + 2k
    of Ut, the scratch of the term being formed, and replaced by Uᵀ there.
    """
    k = slots.size
    B = Ut[r : r + 2 * k]
    T = np.zeros((2 * k, 2 * k))
    M = np.zeros((2 * k, 2 * k))
    v = np.zeros(2 * k)
    nis = np.empty(k)
    Hs = np.empty((k, 2, 5))
    idx = np.empty(5, dtype=np.int64)
    xc, zhat, Hx, Hm = np.empty(5), np.empty(2), np.empty((2, 3)), np.empty((2, 2))
    q, outcome, S = k, APPLIED, np.zeros((2, 2))
    for j in range(k):
        b = 2 * j
        e = n_robot + 2 * slots[j]
        idx[0], idx[1], idx[2], idx[3], idx[4] = 0, 1, 2, e, e + 1
        for c in range(5):  # x_{j−1}[idx]
            acc = x[idx[c]]
            for a in range(b):
                acc += B[a, idx[c]] * v[a]
            xc[c] = acc
        H = Hs[j]
        if current:
            _jacobian(xc[:3].copy(), xc[3:].copy(), zhat, Hx, Hm, H)
        else:
            _jacobian(XL[j], ML[j], zhat, Hx, Hm, H)
        _hp_one(P, n, Ut, Ust, r, e, H, B[b : b + 2])  # B_j = H_j P_0
        G = np.empty((b, 2))
        for a in range(b):
            for c in range(2):
                acc = 0.0
                for d in range(5):
                    acc += B[a, idx[d]] * H[c, d]
                G[a, c] = acc
        MG = np.zeros((b, 2))
        for a in range(b):
            for d in range(b):
                m_ad = M[a, d]
                MG[a, 0] += m_ad * G[d, 0]
                MG[a, 1] += m_ad * G[d, 1]
        S = np.empty((2, 2))
        for a in range(2):
            for c in range(2):
                acc = 0.0
                for d in range(5):
                    acc += B[b + a, idx[d]] * H[c, d]
                for d in range(b):
                    acc -= G[d, a] * MG[d, c]
                S[a, c] = acc
        S[0, 1] = S[1, 0] = 0.5 * (S[0, 1] + S[1, 0])
        S += R[j]
        L, ok = _cholesky(S)
        if not ok:
            q, outcome = j, S_INDEFINITE
            break
        Linv = _lower_inverse(L)
        nu = _innovation(xc, 3, Z[j], zhat, Hx, Hm)
        ee = np.array([Linv[0, 0] * nu[0], Linv[1, 0] * nu[0] + Linv[1, 1] * nu[1]])  # L⁻¹ ν
        t = np.empty((b + 2, 2))  # [−M G; I₂] L⁻ᵀ
        for a in range(b):
            t[a, 0] = -MG[a, 0] * Linv[0, 0]
            t[a, 1] = -(MG[a, 0] * Linv[1, 0] + MG[a, 1] * Linv[1, 1])
        t[b, 0], t[b, 1], t[b + 1, 0], t[b + 1, 1] = Linv[0, 0], Linv[1, 0], 0.0, Linv[1, 1]
        nis[j] = ee[0] * ee[0] + ee[1] * ee[1]
        if not (np.isfinite(nis[j]) and np.all(np.isfinite(t))):
            q, outcome = j, NOT_FINITE
            break
        for a in range(b + 2):
            T[a, b], T[a, b + 1] = t[a, 0], t[a, 1]
            v[a] += t[a, 0] * ee[0] + t[a, 1] * ee[1]
            for d in range(b + 2):
                M[a, d] += t[a, 0] * t[d, 0] + t[a, 1] * t[d, 1]
    if q == 0:
        return q, r, outcome, 0, 0.0, nis[:0], Hs[:0], S, True
    c = 2 * q
    # dx = Bᵀ v and Ust = −Tᵀ B by BLAS on the C-ordered rows of Ut and Ust read as Fortran N × c matrices (B_F = Bᵀ; the
    # leading dimensions are the row strides): dx = B_F v, Ust_F = −B_F T; then Ut's rows ← Uᵀ = −Ust (replacing B)
    U, Us, dx = Ut[r : r + c], Ust[r : r + c], np.zeros(n)
    Tc = np.ascontiguousarray(T[:c, :c])
    ints = np.array([n, c, Ut.strides[0] // 8, Ust.strides[0] // 8, 1], dtype=np.int32)  # m, n = k = ldb, lda, ldc, inc
    flags = np.array([78, 84], dtype=np.uint8)  # "N", "T"
    scalars = np.array([1.0, 0.0, -1.0])
    vc = v[:c].copy()
    _dgemv(
        flags.ctypes,
        ints.ctypes,
        ints[1:].ctypes,
        scalars.ctypes,
        U.ctypes,
        ints[2:].ctypes,
        vc.ctypes,
        ints[4:].ctypes,
        scalars[1:].ctypes,
        dx.ctypes,
        ints[4:].ctypes,
    )
    # Tc read as Fortran is Tᵀ, so transb "T" makes op = T
    _dgemm(
        flags.ctypes,
        flags[1:].ctypes,
        ints.ctypes,
        ints[1:].ctypes,
        ints[1:].ctypes,
        scalars[2:].ctypes,
        U.ctypes,
        ints[2:].ctypes,
        Tc.ctypes,
        ints[1:].ctypes,
        scalars[1:].ctypes,
        Us.ctypes,
        ints[3:].ctypes,
    )
    for a in range(c):
        u, us = U[a], Us[a]
        for i in range(n):
            u[i] = -us[i]
    for i in range(n):
        if not np.isfinite(dx[i]):
            return q, r, outcome, 0, 0.0, nis[:q], Hs[:q], S, False
    s = -np.ones(c)
    td, tr, to = low_rank_entries(U, s, n, n_robot)  # a non-finite U makes the diagonal non-finite: the checks fail
    pd, pr, po = pend
    sd, sr, so = stored
    m = to.size
    if entries_failure((sd[:n], pd[:n], td), (sr, pr, tr), (so[:m], po[:m], to), n_robot)[0] != OK:
        return q, r, outcome, 0, 0.0, nis[:q], Hs[:q], S, False
    x += dx
    x[2] = wrap(x[2])
    sg[r : r + c] = -1.0
    pd[:n] += td
    pr += tr
    po[:m] += to
    return q, r + c, outcome, 0, 0.0, nis[:q], Hs[:q], S, True


@njit(cache=True)
def correct_run(P, n, Ut, Ust, sg, r, pend, stored, x, slots, XL, ML, current, Z, R, joseph, n_robot):
    """Sequential updates with observations Z (k, 2), noise R (k, 2, 2) of landmark slots (k,), in order, until one is not
    applied: the standard form in the span of the rows' H_j P_0 (:func:`_projected_run`), and row by row
    (:func:`innovation_one` and :func:`correct` each) in the Joseph form or when the projected run's covariance checks
    fail (to find the row that fails them).

    H of row j is taken at (XL[j], ML[j]), or at the current estimate if ``current`` (x moves with every update).
    Returns (q, r, outcome, k, value, NIS (k,), H (k, 2, 5), S): rows 0 … q − 1 applied (their NIS and the Jacobians
    H = [H_x, H_m] they were linearised with), r the pending term's new rank; q < k: row q failed with ``outcome``
    (:func:`correct`'s, its k and value; S its innovation covariance).
    """
    if not joseph:
        q, r1, outcome, k, value, nis, Hs, S, checked = _projected_run(
            P, n, Ut, Ust, sg, r, pend, stored, x, slots, XL, ML, current, Z, R, n_robot
        )
        if checked:
            return q, r1, outcome, k, value, nis, Hs, S
    return _rows_run(P, n, Ut, Ust, sg, r, pend, stored, x, slots, XL, ML, current, Z, R, joseph, n_robot)


@njit(cache=True)
def chain_geometry(x0, delta, lin, Q):
    """The geometry of a chain of K body increments δ_k (K, 3) from pose x0 (3,), one pass:

    poses x_{k+1} = x_k ⊕ δ_k (K + 1, 3; the headings are running sums, wrapped on output, as
    :func:`~slamarena.datasets.geometry.accumulate`), the world-frame displacements at the linearisation poses
    D_k = R(θ̆_k) δ_k,xy (K, 2) — θ̆_k from ``lin`` (K, 3), or the chain's own x_k when ``lin`` is empty —, and Q (K, 3, 3)
    rotated in place to the world frame, Q_k ← Rot(θ̆_k) Q_k Rot(θ̆_k)ᵀ, Rot = blockdiag(R(θ̆), 1) (Q empty: nothing).
    """
    K = delta.shape[0]
    poses = np.empty((K + 1, 3))
    D = np.empty((K, 2))
    heading = x0[2]
    px, py = x0[0], x0[1]
    poses[0, 0], poses[0, 1], poses[0, 2] = px, py, wrap(heading)
    R = np.empty((3, 3))
    T = np.empty((3, 3))
    for k in range(K):
        c, s = np.cos(heading), np.sin(heading)
        px += c * delta[k, 0] - s * delta[k, 1]
        py += s * delta[k, 0] + c * delta[k, 1]
        if lin.shape[0]:
            c, s = np.cos(lin[k, 2]), np.sin(lin[k, 2])
        D[k, 0] = c * delta[k, 0] - s * delta[k, 1]
        D[k, 1] = s * delta[k, 0] + c * delta[k, 1]
        heading += delta[k, 2]
        poses[k + 1, 0], poses[k + 1, 1], poses[k + 1, 2] = px, py, wrap(heading)
        if Q.shape[0]:
            R[:] = 0.0
            R[0, 0], R[0, 1], R[1, 0], R[1, 1], R[2, 2] = c, -s, s, c, 1.0
            T[:] = R @ Q[k]
            Q[k] = T @ R.T
    return poses, D


@njit(cache=True)
def robot_chain(P0, D, Q):
    K = D.shape[0]
    out = np.empty((K, 3, 3))
    P = P0.copy()
    G = np.eye(3)
    T = np.empty((3, 3))
    for k in range(K):
        G[0, 2] = -D[k, 1]
        G[1, 2] = D[k, 0]
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for c in range(3):
                    acc += G[a, c] * P[c, b]
                T[a, b] = acc
        for a in range(3):
            for b in range(a, 3):
                acc = 0.0
                for c in range(3):
                    acc += T[a, c] * G[b, c]
                v = acc + 0.5 * (Q[k, a, b] + Q[k, b, a])
                P[a, b] = v
                P[b, a] = v
        out[k] = P
    return out


@njit(cache=True)
def semidefinite(covs):
    """Whether every 3 × 3 covariance of covs (K, 3, 3) is finite and positive semi-definite: its least eigenvalue
    ≥ −1e-12 · max(1, the largest |entry| of covs)."""
    if not np.all(np.isfinite(covs)):
        return False
    tol = -1e-12 * max(1.0, np.abs(covs).max())
    for k in range(covs.shape[0]):
        if np.linalg.eigvalsh(covs[k])[0] < tol:
            return False
    return True


@njit(cache=True)
def cross_covariances(P, n, Dsum):
    """Φ P_rm (3, n − 3), Φ = I + [[0, 0, −ΣD_y], [0, 0, ΣD_x], 0], from the robot rows of P (one contiguous pass), and
    whether it is finite."""
    out = np.empty((3, n - 3))
    finite = True
    for i in range(3, n):
        p2 = P[2, i]
        out[0, i - 3] = P[0, i] - Dsum[1] * p2
        out[1, i - 3] = P[1, i] + Dsum[0] * p2
        out[2, i - 3] = p2
    for a in range(3):
        finite &= np.all(np.isfinite(out[a]))
    return out, finite


@njit(cache=True)
def set_robot_block(P, n, P_rr, P_rm):
    """P[0:3, 0:3] = P_rr, P[0:3, 3:n] = P_rm and P[3:n, 0:3] = P_rmᵀ, in place."""
    P[:3, :3] = P_rr
    P[:3, 3:n] = P_rm
    for i in range(3, n):
        for a in range(3):
            P[i, a] = P_rm[a, i - 3]


@njit(cache=True)
def predict_chain(P, n, x, delta, lin, Q_body, Q_world, first_from, shift, commit_indefinite):
    """One prediction chain of K body increments δ (K, 3), computed and checked before the state changes, then committed.

    :func:`chain_geometry` (Q_body (K, 3, 3) rotated to the world frame in place, or empty when Q_world (K, 3, 3) is given),
    then the linearisation's corrections: ``D_0 = x_1 − first_from`` if first_from (2,) is given (FEJ/OC: the chain starts
    at the robot's linearisation point), ``D_{K−1} += shift`` if shift (2,) is given (OC's re-anchoring);
    :func:`robot_chain`, :func:`cross_covariances` with ΣD, and the checks: every pose, robot covariance and
    cross-covariance finite, every robot covariance :func:`semidefinite`. Committed — :func:`set_robot_block` and
    x[:3] = x_K — if all pass, or if only the semidefiniteness fails and ``commit_indefinite``.
    Returns (poses (K + 1, 3), covs (K, 3, 3), D (K, 2), outcome, k): :data:`APPLIED`, :data:`NOT_FINITE` (k: the first
    piece with a non-finite pose or covariance, K − 1 for a non-finite cross-covariance; nothing committed) or
    :data:`ROBOT_INDEFINITE` (a robot covariance is indefinite; committed only if ``commit_indefinite``).
    """
    poses, D = chain_geometry(x[:3].copy(), delta, lin, Q_body)
    K = D.shape[0]
    if first_from.size:
        D[0, 0], D[0, 1] = poses[1, 0] - first_from[0], poses[1, 1] - first_from[1]
    if shift.size:
        D[K - 1, 0] += shift[0]
        D[K - 1, 1] += shift[1]
    covs = robot_chain(P[:3, :3].copy(), D, Q_body if Q_world.shape[0] == 0 else Q_world)
    Dsum = np.zeros(2)
    for k in range(K):
        Dsum[0] += D[k, 0]
        Dsum[1] += D[k, 1]
    P_rm, cross_finite = cross_covariances(P, n, Dsum)
    for k in range(K):
        if not (np.all(np.isfinite(poses[k + 1])) and np.all(np.isfinite(covs[k]))):
            return poses, covs, D, NOT_FINITE, k
    if not cross_finite:
        return poses, covs, D, NOT_FINITE, K - 1
    outcome = APPLIED if semidefinite(covs) else ROBOT_INDEFINITE
    if outcome == APPLIED or commit_indefinite:
        set_robot_block(P, n, covs[K - 1], P_rm)
        x[:3] = poses[K]
    return poses, covs, D, outcome, 0
