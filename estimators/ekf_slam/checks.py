"""Positive-definiteness checks of the EKF-SLAM covariance (cheap necessary conditions).

A full test that the N × N covariance is positive semi-definite costs O(N³); the filter
instead checks what can be checked in O(N): no negative diagonal entry, the 3 × 3 robot block
and every 2 × 2 landmark block positive semi-definite, and that every innovation covariance S
admits a Cholesky factor. The checks read only those entries (:func:`covariance_entries`; the
entries of a low-rank term ``C diag(s) Cᵀ`` by :func:`low_rank_entries`, O(N d)), so a step's
result is checked before it is committed (:func:`check_entries` on the entries P would have,
:func:`check_augmented` for a new landmark), and a failing step leaves P as it was. A failure
raises :class:`CovarianceError` (or is counted, when the filter is told to record instead of raise).
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["CovarianceError", "check_innovation_cov", "covariance_entries", "low_rank_entries", "check_entries",
           "check_covariance", "check_augmented"]

#: relative tolerance for "negative" (round-off of a semi-definite zero block is not an error)
_TOL = 1e-12

#: the checked entries: the diagonal d (N,), the robot block (3, 3), ``off[k] = P[s + 1, s]`` of landmark k (n,)
Entries = tuple[np.ndarray, np.ndarray, np.ndarray]


class CovarianceError(FloatingPointError):
    """The covariance lost positive (semi-)definiteness."""


def check_innovation_cov(S: np.ndarray) -> np.ndarray:
    """Cholesky factor of the innovation covariance S; raises CovarianceError if S is not PD."""
    try:
        return np.linalg.cholesky(S)
    except np.linalg.LinAlgError as exc:
        raise CovarianceError(f"innovation covariance is not positive definite: S = {S.tolist()}") from exc


def _psd3(A: np.ndarray, tol: float) -> bool:
    """3 × 3 symmetric A is PSD iff every principal minor is ≥ 0 (up to tol)."""
    (a, b, c), (_, d, e), (_, _, f) = A.tolist()
    minors2 = (a * d - b * b, a * f - c * c, d * f - e * e)
    det = a * (d * f - e * e) - b * (b * f - c * e) + c * (b * e - c * d)
    scale2 = max(tol, 1e-300) / _TOL
    return min(a, d, f) >= -tol and min(minors2) >= -tol * scale2 and det >= -tol * scale2 * scale2


def covariance_entries(P: np.ndarray, n_robot: int = 3) -> Entries:
    """The checked entries of P, read from its lower triangle (O(N))."""
    return np.diagonal(P).copy(), P[:n_robot, :n_robot].copy(), np.diagonal(P, offset=-1)[n_robot::2].copy()


def low_rank_entries(C: np.ndarray, s: np.ndarray, n_robot: int = 3) -> Entries:
    """The checked entries of ``C diag(s) Cᵀ`` (C N × d), O(N d)."""
    return _low_rank_entries(np.ascontiguousarray(C, dtype=np.float64), np.ascontiguousarray(s, dtype=np.float64), n_robot)


@njit(cache=True)
def _low_rank_entries(C, s, n_robot):
    N, d = C.shape
    diag, robot, off = np.zeros(N), np.zeros((n_robot, n_robot)), np.zeros((N - n_robot) // 2)
    for i in range(N):
        for k in range(d):
            diag[i] += C[i, k] * C[i, k] * s[k]
    for a in range(n_robot):
        for b in range(n_robot):
            for k in range(d):
                robot[a, b] += C[a, k] * C[b, k] * s[k]
    for j in range(off.size):
        i = n_robot + 2 * j
        for k in range(d):
            off[j] += C[i + 1, k] * C[i, k] * s[k]
    return diag, robot, off


def check_covariance(P: np.ndarray, n_robot: int = 3) -> None:
    """Raise CovarianceError if P has a negative diagonal entry or an indefinite robot/landmark block."""
    check_entries(*covariance_entries(P, n_robot), n_robot)


def check_augmented(entries: Entries, block: np.ndarray, n_robot: int = 3) -> None:
    """:func:`check_entries` of the covariance with these entries grown by a landmark whose 2 × 2 covariance is ``block``."""
    d, robot, off = entries
    check_entries(np.r_[d, np.diagonal(block)], robot, np.r_[off, block[1, 0]], n_robot)


def check_entries(d: np.ndarray, robot: np.ndarray, off: np.ndarray, n_robot: int = 3) -> None:
    """The checks on the entries they read: the diagonal d, the robot block, and ``off[k] = P[s + 1, s]`` of landmark k."""
    scale = max(float(d.max(initial=0.0)), 1.0)
    if not np.all(np.isfinite(d)):
        raise CovarianceError("covariance has non-finite diagonal entries")
    if d.min(initial=0.0) < -_TOL * scale:
        k = int(np.argmin(d))
        raise CovarianceError(f"covariance diagonal entry {k} is negative: {d[k]!r}")
    if not _psd3(robot, _TOL * scale):
        raise CovarianceError("robot covariance block is not positive semi-definite")
    if off.size:
        det = d[n_robot::2] * d[n_robot + 1::2] - off * off
        if det.min() < -_TOL * scale * scale:
            k = int(np.argmin(det))
            raise CovarianceError(f"covariance block of landmark slot {k} is not positive semi-definite (det {det[k]!r})")
