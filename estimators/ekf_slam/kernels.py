"""The inner loops of EKF-SLAM (numba): the O(N²) covariance update and the robot-block chain.

``symmetric_update(buffer, n, C, s)`` applies ``P ← P + C diag(s) Cᵀ`` to the live block
``P = buffer[:n, :n]`` (C is n × d, d small). Element (i, j) receives ``Σ_k (C_ik C_jk) s_k``; the
product ``C_ik C_jk`` is commutative and the sum runs in the same order for (j, i), so a
symmetric P stays bitwise symmetric without a separate symmetrisation pass. The loop makes
one row-major pass over the contiguous buffer (memory-bound, vectorised by LLVM), several
times faster than a rank-2 BLAS product plus an N × N add. For larger d (batched updates) the
BLAS product ``C Cᵀ`` (numpy calls syrk for this pattern, which is exactly symmetric) is used
per sign.

``robot_chain(P0, D, Q)`` runs the 3 × 3 robot-block recursion of a chain of K predictions,
``P_{k+1} = G_k P_k G_kᵀ + Q_k`` with ``G_k = I + [[0, 0, −D_k,y], [0, 0, D_k,x], [0, 0, 0]]``,
and returns every P_k (K, 3, 3).
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["symmetric_update", "robot_chain"]

#: largest d handled by the fused loop
_FUSED_MAX = 8


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


def symmetric_update(buffer: np.ndarray, n: int, C: np.ndarray, s: np.ndarray) -> None:
    """buffer[:n, :n] += C diag(s) Cᵀ in place (buffer C-contiguous, C n × d, s (d,))."""
    s = np.ascontiguousarray(s, dtype=np.float64)
    if C.shape[1] <= _FUSED_MAX:
        _fused(buffer, n, np.ascontiguousarray(C.T), s)
        return
    P = buffer[:n, :n]
    for sign in np.unique(s):
        cols = C[:, s == sign] * np.sqrt(abs(sign))
        if sign > 0:
            P += cols @ cols.T
        else:
            P -= cols @ cols.T


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
