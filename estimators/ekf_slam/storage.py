"""Growing EKF-SLAM state storage with amortised capacity, and the deferred covariance update.

The state ``x`` (N,) and covariance ``P`` (N, N) live in preallocated buffers of size
``capacity ≥ N``; ``x`` and ``P`` are views of the live part. When a new landmark does not
fit, the capacity doubles and the live part is copied once, so adding n landmarks costs
O(N²) copies in total — O(N) amortised per landmark instead of an O(N²) copy each time.

Deferred update. The covariance is ``P = P_stored + U diag(s) Uᵀ`` with a pending low-rank term
``U`` (N × r) that :meth:`GrowingState.defer` extends by the columns of one update and
:meth:`GrowingState.flush` applies in one pass over the buffer (:func:`.kernels.symmetric_update`).
While a term is pending, the update needs only a few columns of P, which cost O(N r)
(:meth:`GrowingState.columns`; ``filter.py`` derives why this is the sequential update exactly).
Entries added while a term is pending (a new landmark) have zero rows in ``U``: their stored
cross-covariances were computed from the current P, so the earlier terms are already in them.
Reading :attr:`GrowingState.P` flushes first, so it is always the current covariance.
"""
from __future__ import annotations

import numpy as np

from .kernels import symmetric_update

__all__ = ["GrowingState"]


class GrowingState:
    """``x``/``P`` views of capacity-doubling buffers, with a pending symmetric low-rank update of P."""

    def __init__(self, n_state: int = 3, capacity: int = 64):
        capacity = max(int(capacity), n_state)
        self.n = int(n_state)
        self._x = np.zeros(capacity)
        self._P = np.zeros((capacity, capacity))
        self._U = np.zeros((self.n, 0))
        self._s = np.zeros(0)

    @property
    def capacity(self) -> int:
        return self._x.shape[0]

    @property
    def x(self) -> np.ndarray:
        return self._x[: self.n]

    @property
    def P(self) -> np.ndarray:
        """The current covariance (the pending term applied first)."""
        self.flush()
        return self._P[: self.n, : self.n]

    @property
    def stored(self) -> np.ndarray:
        """The stored covariance P_stored (without the pending term)."""
        return self._P[: self.n, : self.n]

    @property
    def pending(self) -> tuple[np.ndarray, np.ndarray]:
        """The pending term (U (N × r), s (r,)): P = P_stored + U diag(s) Uᵀ."""
        return self._U, self._s

    def defer(self, C: np.ndarray, s: np.ndarray) -> None:
        """Add ``C diag(s) Cᵀ`` (C N × d) to the pending term."""
        self._U = np.hstack([self._U, C])
        self._s = np.r_[self._s, s]

    def columns(self, idx) -> np.ndarray:
        """The current ``P[:, idx]`` (N × len(idx)), O(N r) without a flush."""
        U, s = self._U, self._s
        return self.stored[:, idx] + (U * s) @ U[idx].T

    def rows(self, idx) -> np.ndarray:
        """The current ``P[idx, :]``."""
        return self.columns(idx).T

    def flush(self) -> None:
        """Apply the pending term to the stored covariance (one pass over P)."""
        if self._s.size:
            symmetric_update(self._P, self.n, self._U, self._s)
            self._U, self._s = np.zeros((self.n, 0)), np.zeros(0)

    def grow(self, extra: int) -> slice:
        """Append ``extra`` zero-initialised state entries; returns their slice of ``x``."""
        start, stop = self.n, self.n + int(extra)
        if stop > self.capacity:
            capacity = max(2 * self.capacity, stop)
            x = np.zeros(capacity)
            P = np.zeros((capacity, capacity))
            x[:start] = self._x[:start]
            P[:start, :start] = self._P[:start, :start]
            self._x, self._P = x, P
        self._x[start:stop] = 0.0
        self._P[start:stop, :stop] = 0.0
        self._P[:stop, start:stop] = 0.0
        self._U = np.vstack([self._U, np.zeros((stop - start, self._U.shape[1]))])
        self.n = stop
        return slice(start, stop)
