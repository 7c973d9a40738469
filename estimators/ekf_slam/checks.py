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

from ..inputs import PSD_TOL as _TOL
from ..inputs import CovarianceError
from ..inputs import psd3 as _psd3

__all__ = [
    "CovarianceError",
    "innovation_cov_error",
    "covariance_entries",
    "low_rank_entries",
    "entries_failure",
    "entries_error",
    "check_entries",
    "check_covariance",
    "check_augmented",
]

#: the checked entries: the diagonal d (N,), the robot block (3, 3), ``off[k] = P[s + 1, s]`` of landmark k (n,)
Entries = tuple[np.ndarray, np.ndarray, np.ndarray]


def innovation_cov_error(S: np.ndarray) -> CovarianceError:
    """The error of an innovation covariance S that has no Cholesky factor."""
    return CovarianceError(f"innovation covariance is not positive definite: S = {np.asarray(S).tolist()}")


#: what :func:`entries_failure` found: nothing, a non-finite diagonal, a negative diagonal entry, an indefinite robot block,
#: an indefinite landmark block
OK, NONFINITE_DIAGONAL, NEGATIVE_DIAGONAL, ROBOT_BLOCK, LANDMARK_BLOCK = 0, 1, 2, 3, 4


@njit(cache=True)
def _entry(parts, i):
    """The sum of the parts' i-th entries, left to right (as ``parts[0] + parts[1] + …``)."""
    v = 0.0
    for p in parts:
        v += p[i]
    return v


@njit(cache=True)
def entries_failure(d, robot, off, n_robot):
    """The first failed check on the entries (:data:`OK` … :data:`LANDMARK_BLOCK`, the index k and the offending value), O(N).

    Each argument is a tuple of parts whose sum is the entries (the stored P's, the pending term's and a new term's;
    summed on the fly, no temporaries): one pass over the diagonal (finite, its largest and its least entry), the robot
    block, one pass over the landmark blocks' determinants."""
    n = d[0].size
    scale, k, least = 1.0, 0, np.inf
    for i in range(n):
        v = _entry(d, i)
        if not np.isfinite(v):
            return NONFINITE_DIAGONAL, i, v
        scale = max(scale, v)
        if v < least:
            k, least = i, v
    tol = _TOL * scale
    if least < -tol:  # the most negative entry, if any is below −tol
        return NEGATIVE_DIAGONAL, k, least
    R = np.zeros((n_robot, n_robot))
    for part in robot:
        R += part
    if not _psd3(R, tol):
        return ROBOT_BLOCK, 0, 0.0
    k, least = 0, np.inf
    for j in range(off[0].size):
        o = _entry(off, j)
        det = _entry(d, n_robot + 2 * j) * _entry(d, n_robot + 2 * j + 1) - o * o
        if det < least:
            k, least = j, det
    if least < -tol * scale:
        return LANDMARK_BLOCK, k, least
    return OK, 0, 0.0


def entries_error(code: int, k: int, value: float) -> CovarianceError:
    """The error :func:`check_entries` raises for a failure found by :func:`entries_failure`."""
    return CovarianceError(
        {
            NONFINITE_DIAGONAL: "covariance has non-finite diagonal entries",
            NEGATIVE_DIAGONAL: f"covariance diagonal entry {k} is negative: {value!r}",
            ROBOT_BLOCK: "robot covariance block is not positive semi-definite",
            LANDMARK_BLOCK: f"covariance block of landmark slot {k} is not positive semi-definite (det {value!r})",
        }[code]
    )


def covariance_entries(P: np.ndarray, n_robot: int = 3) -> Entries:
    """The checked entries of P, read from its lower triangle (O(N))."""
    return np.diagonal(P).copy(), P[:n_robot, :n_robot].copy(), np.diagonal(P, offset=-1)[n_robot::2].copy()


@njit(cache=True)
def low_rank_entries(Ct, s, N, n_robot):
    """The checked entries of ``C diag(s) Cᵀ`` (C N × c, given as the first N columns of the rows of Ct (c, ≥ N)), O(N c)."""
    c = s.size
    diag, robot, off = np.zeros(N), np.zeros((n_robot, n_robot)), np.zeros((N - n_robot) // 2)
    for k in range(c):
        u, sk = Ct[k], s[k]
        for i in range(N):
            diag[i] += u[i] * u[i] * sk
        for a in range(n_robot):
            for b in range(n_robot):
                robot[a, b] += u[a] * u[b] * sk
        for j in range(off.size):
            i = n_robot + 2 * j
            off[j] += u[i + 1] * u[i] * sk
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
    code, k, value = entries_failure(
        (np.ascontiguousarray(d, dtype=np.float64),),
        (np.ascontiguousarray(robot, dtype=np.float64),),
        (np.ascontiguousarray(off, dtype=np.float64),),
        n_robot,
    )
    if code != OK:
        raise entries_error(code, k, value)
