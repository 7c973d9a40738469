"""Positive-definiteness checks of the EKF-SLAM covariance (cheap necessary conditions).

A full test that the N × N covariance is positive semi-definite costs O(N³); the filter
instead checks what can be checked in O(N): no negative diagonal entry, the 3 × 3 robot block
and every 2 × 2 landmark block positive semi-definite, and that every innovation covariance S
admits a Cholesky factor. The checks read only those entries, so a step's result is checked
before it is committed (:func:`check_update` for ``P + C diag(s) Cᵀ``, :func:`check_augmented`
for a new landmark), and a failing step leaves P as it was. A failure raises
:class:`CovarianceError` (or is counted, when the filter is told to record instead of raise).
"""
from __future__ import annotations

import numpy as np

__all__ = ["CovarianceError", "check_innovation_cov", "check_covariance", "check_update", "check_augmented"]

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
    _check_entries(*_entries(P, None, None, n_robot), n_robot)


def _entries(P: np.ndarray, C: np.ndarray | None, s: np.ndarray | None, n_robot: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The checked entries of ``P + C diag(s) Cᵀ`` (C N × d, or None): diagonal, robot block, ``[s, s + 1]`` of each landmark; O(N d)."""
    d, robot, off = np.diagonal(P), P[:n_robot, :n_robot], np.diagonal(P, offset=1)[n_robot::2]
    if C is None or C.shape[1] == 0:
        return d, robot, off
    Cs = C * s
    return (d + np.einsum("ik,ik->i", Cs, C), robot + Cs[:n_robot] @ C[:n_robot].T,
            off + np.einsum("ik,ik->i", Cs[n_robot::2], C[n_robot + 1::2]))


def check_update(P: np.ndarray, C: np.ndarray, s: np.ndarray, n_robot: int = 3) -> None:
    """:func:`check_covariance` of ``P + C diag(s) Cᵀ`` (C N × d) before it is formed: only the checked entries, O(N d)."""
    _check_entries(*_entries(P, C, s, n_robot), n_robot)


def check_augmented(P: np.ndarray, block: np.ndarray, C: np.ndarray | None = None, s: np.ndarray | None = None, n_robot: int = 3) -> None:
    """:func:`check_covariance` of ``P + C diag(s) Cᵀ`` (a pending update, if given) grown by a landmark whose 2 × 2
    covariance is ``block``, before it is grown."""
    d, robot, off = _entries(P, C, s, n_robot)
    _check_entries(np.r_[d, np.diagonal(block)], robot, np.r_[off, block[0, 1]], n_robot)


def _check_entries(d: np.ndarray, robot: np.ndarray, off: np.ndarray, n_robot: int) -> None:
    """The checks on the entries they read: the diagonal d, the robot block, and ``off[k] = P[s, s + 1]`` of landmark k."""
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
