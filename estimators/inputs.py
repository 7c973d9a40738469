"""What every filter checks in its input before its state changes (shared by EKF-SLAM and FastSLAM).

* observation rows (k, 3) = [range, bearing, id]: a row with a non-finite value or a negative range is
  dropped and counted (:func:`valid_rows`);
* stamps: an update's time t must be finite and not before the last update's (:func:`next_stamp`);
  a step with a bad stamp raises ``ValueError`` before anything changes;
* covariances: a 3 × 3 covariance (a robot block, a chain of motion covariances) must be positive
  semi-definite — :func:`psd3` by its principal minors (O(1) each, compiled), :func:`first_indefinite`
  over a chain; a failure is a :class:`CovarianceError`.

A filter states what else it cannot represent (a prediction or an update whose result is not finite)
in its own module; both then check the result before committing it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["CovarianceError", "valid_rows", "next_stamp", "psd3", "first_indefinite", "PSD_TOL"]

#: relative tolerance for "negative" (round-off of a semi-definite zero block is not an error)
PSD_TOL = 1e-12


class CovarianceError(FloatingPointError):
    """The covariance lost positive (semi-)definiteness."""


def valid_rows(z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of an observation set z (k, 3) that are finite with a non-negative range; the mask of the finite rows
    (``finite``, (k,)) and of the finite rows with a negative range (``negative``, (k,)), for the counts."""
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or z.shape[1] != 3:
        raise ValueError(f"z must be a (k, 3) array [range, bearing, id], got shape {z.shape}")
    finite = np.all(np.isfinite(z), axis=1)
    negative = finite & (z[:, 0] < 0)
    return z[finite & ~negative], finite, negative


def next_stamp(t: float, last: float | None) -> float:
    """The stamp t of an update that follows one at ``last`` (None: the first): finite and ≥ last, else ValueError."""
    t = float(t)
    if not math.isfinite(t):
        raise ValueError(f"update: the stamp t must be finite, got {t!r}; the state is unchanged")
    if last is not None and t < last:
        raise ValueError(
            f"update: stamp t = {t!r} s is before the last update's ({last!r} s): stamps must not go back in time; "
            "the state is unchanged"
        )
    return t


@njit(cache=True)
def psd3(A, tol):
    """3 × 3 symmetric A is PSD iff every principal minor is ≥ 0 (up to tol)."""
    a, b, c, d, e, f = A[0, 0], A[0, 1], A[0, 2], A[1, 1], A[1, 2], A[2, 2]
    minor2 = min(a * d - b * b, a * f - c * c, d * f - e * e)
    det = a * (d * f - e * e) - b * (b * f - c * e) + c * (b * e - c * d)
    scale2 = max(tol, 1e-300) / PSD_TOL
    return min(a, d, f) >= -tol and minor2 >= -tol * scale2 and det >= -tol * scale2 * scale2


@njit(cache=True)
def first_indefinite(P):
    """The index of the first of the covariances P (K, 3, 3) that is not finite or not PSD (tolerance relative to its
    largest diagonal entry, at least 1), −1 if none."""
    for k in range(P.shape[0]):
        A = P[k]
        if not np.all(np.isfinite(A)):
            return k
        if not psd3(A, PSD_TOL * max(1.0, A[0, 0], A[1, 1], A[2, 2])):
            return k
    return -1
