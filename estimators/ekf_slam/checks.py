"""Positive-definiteness checks of the EKF-SLAM covariance (cheap necessary conditions).

A full test that the N × N covariance is positive semi-definite costs O(N³); the filter
instead checks, after every step, what can be checked in O(N): no negative diagonal entry,
the 3 × 3 robot block and every 2 × 2 landmark block positive semi-definite, and that every
innovation covariance S admits a Cholesky factor. A failure raises :class:`CovarianceError`
(or is counted, when the filter is told to record instead of raise).
"""
from __future__ import annotations

import numpy as np

__all__ = ["CovarianceError", "check_innovation_cov", "check_covariance"]

#: relative tolerance for "negative" (round-off of a semi-definite zero block is not an error)
_TOL = 1e-12


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


def check_covariance(P: np.ndarray, n_robot: int = 3) -> None:
    """Raise CovarianceError if P has a negative diagonal entry or an indefinite robot/landmark block."""
    d = np.diagonal(P)
    scale = max(float(d.max(initial=0.0)), 1.0)
    if not np.all(np.isfinite(d)):
        raise CovarianceError("covariance has non-finite diagonal entries")
    if d.min(initial=0.0) < -_TOL * scale:
        k = int(np.argmin(d))
        raise CovarianceError(f"covariance diagonal entry {k} is negative: {d[k]!r}")
    if not _psd3(P[:n_robot, :n_robot], _TOL * scale):
        raise CovarianceError("robot covariance block is not positive semi-definite")
    n = (P.shape[0] - n_robot) // 2
    if n:
        a = d[n_robot::2]
        c = d[n_robot + 1::2]
        b = np.diagonal(P, offset=1)[n_robot::2]
        det = a * c - b * b
        if det.min() < -_TOL * scale * scale:
            k = int(np.argmin(det))
            raise CovarianceError(f"covariance block of landmark slot {k} is not positive semi-definite (det {det[k]!r})")
