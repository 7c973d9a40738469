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
  ``B = C diag(s)``, ``α = ½`` (``½ (A Bᵀ + B Aᵀ) = C diag(s) Cᵀ``) — called through
  ``scipy.linalg.cython_blas`` so that it works on the strided live block and factor (leading
  dimensions = their row strides) without a copy. At d ≈ 20 the product is compute-bound (O(d N²/2) flops), where the fused loop
  would be several times slower.

``mirror_lower(buffer, n)`` copies the strict lower triangle to the upper one in 8 × 8 tiles
(each written cache line is filled by one tile row), which makes P bitwise symmetric.

``gain_terms(PHt, S, L, ν, joseph)`` is the O(N d) part of one update in one compiled call (the
formulas are stated where it is used, ``filter.py``'s ``_correct``): from ``PHᵀ`` (N × d), the
innovation covariance S (d × d), its Cholesky factor L and ν, the NIS ``νᵀ S⁻¹ ν``, the state step ``K ν`` and the symmetric
terms ``C diag(s) Cᵀ`` of the covariance update.

``innovation_one(P, n, Ut, Ust, r, s, x̆_r, m̆, x, z, R)`` is the O(N r) part of one observation of the landmark at
entries (s, s + 1): ``H`` (2 × 5) at the linearisation point (x̆_r, m̆), ``PHᵀ = P[:, idx] Hᵀ`` read from the
current P (the stored lower triangle and the pending term ``Ustᵀ Ut``, :mod:`.storage`), ``S = H PHᵀ[idx] + R``
and ``ν = z − h(x_r, m)`` at the current estimate. ``correct(…)`` is the rest, shared with the batch form: the
Cholesky factor of S, :func:`gain_terms`, the entries of the update term (:func:`.checks.low_rank_entries`), the
checks of the entries P would have (:func:`.checks.entries_failure`) and, only if all pass, the commit — x += K ν,
the term appended to the pending one. One compiled call each, so an observation costs O(N r) plus a few µs.

``robot_chain(P0, D, Q)`` runs the 3 × 3 robot-block recursion of a chain of K predictions,
``P_{k+1} = G_k P_k G_kᵀ + Q_k`` with ``G_k = I + [[0, 0, −D_k,y], [0, 0, D_k,x], [0, 0, 0]]``,
and returns every P_k (K, 3, 3).
"""
from __future__ import annotations

import ctypes

import numpy as np
from numba import njit
from numba.extending import get_cython_function_address

from ..kernels import range_bearing, wrap
from .checks import OK, entries_failure, low_rank_entries

__all__ = ["update_lower", "mirror_lower", "gain_terms", "innovation_one", "correct", "robot_chain",
           "APPLIED", "S_INDEFINITE", "NOT_FINITE"]

#: largest d handled by the fused loop (above it BLAS is faster)
_FUSED_MAX = 4

_DOUBLE, _INT, _CHAR = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int), ctypes.c_char_p


def _blas(name: str, *args):
    return ctypes.CFUNCTYPE(None, *args)(get_cython_function_address("scipy.linalg.cython_blas", name))


# Fortran BLAS: (uplo, trans, n, k, alpha, a, lda, [b, ldb,] beta, c, ldc)
_dsyrk = _blas("dsyrk", _CHAR, _CHAR, _INT, _INT, _DOUBLE, _DOUBLE, _INT, _DOUBLE, _DOUBLE, _INT)
_dsyr2k = _blas("dsyr2k", _CHAR, _CHAR, _INT, _INT, _DOUBLE, _DOUBLE, _INT, _DOUBLE, _INT, _DOUBLE, _DOUBLE, _INT)


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


def _ref(value, ctype):
    return ctypes.byref(ctype(value))


def update_lower(buffer: np.ndarray, n: int, Ct: np.ndarray, s: np.ndarray) -> None:
    """The lower triangle of buffer[:n, :n] += C diag(s) Cᵀ in place; buffer C-contiguous, Ct = Cᵀ (d × n, rows contiguous), s (d,)."""
    if not (buffer.flags.c_contiguous and buffer.dtype == np.float64 and Ct.dtype == np.float64 and Ct.strides[1] == 8):
        raise ValueError("update_lower needs a C-contiguous float64 buffer and a float64 Cᵀ with contiguous rows")
    s = np.ascontiguousarray(s, dtype=np.float64)
    d = Ct.shape[0]
    if d == 0 or n == 0:
        return
    if d <= _FUSED_MAX:
        _fused(buffer, n, Ct, s)
        return
    # The C-ordered buffer read as a Fortran matrix (leading dimension = its row length) is Pᵀ = P, and
    # Fortran "U" is its C-ordered lower triangle; the C-ordered d × n Cᵀ is the Fortran n × d C
    # (leading dimension = its row stride), so trans="N" forms C Cᵀ.
    c_ptr, a_ptr = buffer.ctypes.data_as(_DOUBLE), Ct.ctypes.data_as(_DOUBLE)
    n_, d_ = _ref(n, ctypes.c_int), _ref(d, ctypes.c_int)
    ld, lda = _ref(buffer.shape[1], ctypes.c_int), _ref(Ct.strides[0] // 8, ctypes.c_int)
    one = _ref(1.0, ctypes.c_double)
    if np.all(s == s[0]):
        _dsyrk(b"U", b"N", n_, d_, _ref(float(s[0]), ctypes.c_double), a_ptr, lda, one, c_ptr, ld)
    else:  # ½ (C Bᵀ + B Cᵀ) with B = C diag(s)
        B = np.ascontiguousarray(Ct * s[:, None])
        _dsyr2k(b"U", b"N", n_, d_, _ref(0.5, ctypes.c_double), a_ptr, lda, B.ctypes.data_as(_DOUBLE), _ref(n, ctypes.c_int), one, c_ptr, ld)


@njit(cache=True)
def gain_terms(PHt, S, L, nu, joseph):
    """(νᵀ S⁻¹ ν, K ν, C, s) with S = L Lᵀ, W = PHᵀ L⁻ᵀ, K = W L⁻¹; standard C = W, s = −1; Joseph C = [W, K + D, K − D],
    s = [−1, ½, −½], D = K S − PHᵀ. One pass over the N rows (d is small: loops, not BLAS calls)."""
    N, d = PHt.shape
    Linv = np.linalg.inv(L)
    e = Linv @ nu                                               # L⁻¹ ν: NIS = eᵀe
    Sinv_nu = Linv.T @ e                                        # S⁻¹ ν
    c = 3 * d if joseph else d
    C = np.empty((N, c))
    dx = np.empty(N)
    k_row = np.empty(d)
    for i in range(N):
        acc = 0.0
        for a in range(d):                                      # dx_i = PHᵀ_i S⁻¹ ν;  W_i = PHᵀ_i L⁻ᵀ
            acc += PHt[i, a] * Sinv_nu[a]
            w = 0.0
            for b in range(a + 1):                              # (L⁻ᵀ)[b, a] = L⁻¹[a, b], zero for b > a
                w += PHt[i, b] * Linv[a, b]
            C[i, a] = w
        dx[i] = acc
        if joseph:
            for a in range(d):                                  # K_i = W_i L⁻¹
                w = 0.0
                for b in range(a, d):                           # L⁻¹[b, a], zero for b < a
                    w += C[i, b] * Linv[b, a]
                k_row[a] = w
            for a in range(d):                                  # D_i = K_i S − PHᵀ_i
                w = -PHt[i, a]
                for b in range(d):
                    w += k_row[b] * S[b, a]
                C[i, d + a] = k_row[a] + w
                C[i, 2 * d + a] = k_row[a] - w
    s = np.empty(c)
    s[:d] = -1.0
    if joseph:
        s[d:2 * d], s[2 * d:] = 0.5, -0.5
    return e @ e, dx, C, s


@njit(cache=True)
def innovation_one(P, n, Ut, Ust, r, s, xl, ml, x, z, R):
    """(PHᵀ (n, 2), S (2, 2), ν (2,)) of one range-bearing observation z of the landmark at entries s, s + 1."""
    zhat, Hx, Hm = np.empty(2), np.empty((2, 3)), np.empty((2, 2))
    range_bearing(xl, ml, zhat, Hx, Hm)                      # H = [H_x, H_m] at the linearisation point
    H = np.empty((2, 5))
    H[:, :3], H[:, 3:] = Hx, Hm
    idx = np.array([0, 1, 2, s, s + 1])
    PHt = np.empty((n, 2))
    for i in range(n):
        if i < s:                                             # left of the block: rows s, s + 1 of the lower triangle
            p3, p4 = P[s, i], P[s + 1, i]
        elif i == s:
            p3, p4 = P[s, s], P[s + 1, s]
        else:                                                 # at and below row s + 1: columns s, s + 1 of the lower triangle
            p3, p4 = P[i, s], P[i, s + 1]
        p0, p1, p2 = P[0, i], P[1, i], P[2, i]                # the robot rows are current
        PHt[i, 0] = H[0, 0] * p0 + H[0, 1] * p1 + H[0, 3] * p3 + H[0, 4] * p4
        PHt[i, 1] = H[1, 0] * p0 + H[1, 1] * p1 + H[1, 2] * p2 + H[1, 3] * p3 + H[1, 4] * p4
    # the pending term: P[:, idx] Hᵀ += Ustᵀ (Ut[:, idx] Hᵀ), one contiguous pass over each of its r rows
    for k in range(r):
        g0, g1 = 0.0, 0.0
        for c in range(5):
            g0 += Ut[k, idx[c]] * H[0, c]
            g1 += Ut[k, idx[c]] * H[1, c]
        a = Ust[k]
        for i in range(n):
            PHt[i, 0] += a[i] * g0
            PHt[i, 1] += a[i] * g1
    S = np.empty((2, 2))
    for a in range(2):
        for b in range(2):
            acc = 0.0
            for c in range(5):
                acc += H[a, c] * PHt[idx[c], b]
            S[a, b] = acc
    S[0, 1] = S[1, 0] = 0.5 * (S[0, 1] + S[1, 0])
    S += R
    range_bearing(x[:3], x[s:s + 2], zhat, Hx, Hm)          # h at the current estimate
    nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
    return PHt, S, nu


#: outcomes of :func:`correct` (a positive value: the failed covariance check, :data:`.checks.NEGATIVE_DIAGONAL` …)
APPLIED, S_INDEFINITE, NOT_FINITE = 0, -1, -2


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
def correct(PHt, S, nu, joseph, x, Ut, Ust, sg, r, pend, stored, n_robot):
    """Check and, if every check passes, commit one update (``filter.py``'s ``_correct`` states the formulas).

    x (N,) is changed in place, the update's term ``C diag(s) Cᵀ`` written to rows r … r + c of Ut, Ust = (C diag(s))ᵀ
    and sg = s, its entries added to the pending ones ``pend`` (diagonal (≥N,), robot block, landmark off-diagonals);
    ``stored``: the entries of the stored P. Returns (outcome, NIS, k, value): :data:`APPLIED`, :data:`S_INDEFINITE`,
    :data:`NOT_FINITE`, or the code of the failed check with its index and value (:func:`.checks.entries_failure`).
    """
    L, ok = _cholesky(S)
    if not ok:
        return S_INDEFINITE, np.nan, 0, 0.0
    nis, dx, C, s = gain_terms(PHt, S, L, nu, joseph)
    if not (np.isfinite(nis) and np.all(np.isfinite(dx)) and np.all(np.isfinite(C))):
        return NOT_FINITE, nis, 0, 0.0
    N, c = C.shape
    td, tr, to = low_rank_entries(C, s, n_robot)
    pd, pr, po = pend
    sd, sr, so = stored
    m = to.size
    code, k, value = entries_failure(sd[:N] + pd[:N] + td, sr + pr + tr, so[:m] + po[:m] + to, n_robot)
    if code != OK:
        return code, nis, k, value
    x += dx
    x[2] = wrap(x[2])
    for j in range(c):
        sg[r + j] = s[j]
        for i in range(N):
            Ut[r + j, i] = C[i, j]
            Ust[r + j, i] = C[i, j] * s[j]
    pd[:N] += td
    pr += tr
    po[:m] += to
    return APPLIED, nis, 0, 0.0


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
