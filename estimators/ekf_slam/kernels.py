"""The inner loops of EKF-SLAM: the O(N²) covariance update (numba, or BLAS in place) and the robot-block chain.

``symmetric_update(buffer, n, C, s)`` applies ``P ← P + C diag(s) Cᵀ`` to the live block
``P = buffer[:n, :n]`` of a C-contiguous buffer (C is n × d), in place, and keeps a symmetric P
**bitwise** symmetric:

* d ≤ ``_FUSED_MAX`` (one observation): a fused numba loop. Element (i, j) receives
  ``Σ_k (C_ik C_jk) s_k``; the product ``C_ik C_jk`` is commutative and the sum runs in the same
  order for (j, i), so P stays bitwise symmetric in one row-major pass over the buffer
  (memory-bound, vectorised by LLVM).
* larger d (a deferred or batched update of a whole observation set, d = 2m … 6m): BLAS on the
  lower triangle in place — ``dsyrk`` (``P + α C Cᵀ``) when every s_k is the same α, else ``dsyr2k``
  with ``A = C``, ``B = ½ C diag(s)`` (``A Bᵀ + B Aᵀ = C diag(s) Cᵀ``) — called through
  ``scipy.linalg.cython_blas`` so that it works on the strided live block (leading dimension = the
  buffer's capacity) without a copy; then the strict lower triangle is copied to the upper one
  (:func:`_mirror_lower`, 8 × 8 tiles: each written cache line is filled by one tile row). The
  rank-d product costs O(d N²) flops in half the matrix; at d ≈ 20 its cost is that of a few
  streaming passes, where the fused loop would be compute-bound.

``robot_chain(P0, D, Q)`` runs the 3 × 3 robot-block recursion of a chain of K predictions,
``P_{k+1} = G_k P_k G_kᵀ + Q_k`` with ``G_k = I + [[0, 0, −D_k,y], [0, 0, D_k,x], [0, 0, 0]]``,
and returns every P_k (K, 3, 3).
"""
from __future__ import annotations

import ctypes

import numpy as np
from numba import njit
from numba.extending import get_cython_function_address

__all__ = ["symmetric_update", "robot_chain"]

#: largest d handled by the fused loop (above it, BLAS on one triangle plus the mirror copy is cheaper)
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
            for j in range(n):
                row[j] += (a * c[j]) * sk


@njit(cache=True)
def _mirror_lower(P, n):
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


def symmetric_update(buffer: np.ndarray, n: int, C: np.ndarray, s: np.ndarray) -> None:
    """buffer[:n, :n] += C diag(s) Cᵀ in place (buffer C-contiguous, C n × d, s (d,))."""
    s = np.ascontiguousarray(s, dtype=np.float64)
    d = C.shape[1]
    if d == 0 or n == 0:
        return
    if d <= _FUSED_MAX:
        _fused(buffer, n, np.ascontiguousarray(C.T), s)
        return
    if not (buffer.flags.c_contiguous and buffer.dtype == np.float64):
        raise ValueError("the covariance buffer must be a C-contiguous float64 array")
    # The C-ordered buffer read as a Fortran matrix (leading dimension = its row length) is Pᵀ = P; the
    # C-ordered n × d C is the Fortran d × n Cᵀ, so trans="T" forms C Cᵀ. Fortran "U" is the C-ordered lower triangle.
    A = np.ascontiguousarray(C, dtype=np.float64)
    c_ptr, a_ptr = buffer.ctypes.data_as(_DOUBLE), A.ctypes.data_as(_DOUBLE)
    n_, d_, ld = _ref(n, ctypes.c_int), _ref(d, ctypes.c_int), _ref(buffer.shape[1], ctypes.c_int)
    one = _ref(1.0, ctypes.c_double)
    if np.all(s == s[0]):
        _dsyrk(b"U", b"T", n_, d_, _ref(float(s[0]), ctypes.c_double), a_ptr, d_, one, c_ptr, ld)
    else:
        B = np.ascontiguousarray(0.5 * A * s)
        _dsyr2k(b"U", b"T", n_, d_, one, a_ptr, d_, B.ctypes.data_as(_DOUBLE), d_, one, c_ptr, ld)
    _mirror_lower(buffer, n)


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
