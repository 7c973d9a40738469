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

``robot_chain(P0, D, Q)`` runs the 3 × 3 robot-block recursion of a chain of K predictions,
``P_{k+1} = G_k P_k G_kᵀ + Q_k`` with ``G_k = I + [[0, 0, −D_k,y], [0, 0, D_k,x], [0, 0, 0]]``,
and returns every P_k (K, 3, 3).
"""
from __future__ import annotations

import ctypes

import numpy as np
from numba import njit
from numba.extending import get_cython_function_address

__all__ = ["update_lower", "mirror_lower", "gain_terms", "robot_chain"]

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
    s = [−1, ½, −½], D = K S − PHᵀ."""
    d = L.shape[0]
    Linv = np.linalg.inv(L)
    W = PHt @ np.ascontiguousarray(Linv.T)
    K = W @ Linv
    e = Linv @ nu
    dx = K @ nu
    if not joseph:
        return e @ e, dx, W, -np.ones(d)
    D = K @ S - PHt
    C = np.empty((PHt.shape[0], 3 * d))
    C[:, :d], C[:, d:2 * d], C[:, 2 * d:] = W, K + D, K - D
    s = np.empty(3 * d)
    s[:d], s[d:2 * d], s[2 * d:] = -1.0, 0.5, -0.5
    return e @ e, dx, C, s


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
