"""Growing EKF-SLAM state storage with amortised capacity.

The state ``x`` (N,) and covariance ``P`` (N, N) live in preallocated buffers of size
``capacity ≥ N``; ``x`` and ``P`` are views of the live part. When a new landmark does not
fit, the capacity doubles and the live part is copied once, so adding n landmarks costs
O(N²) copies in total — O(N) amortised per landmark instead of an O(N²) copy each time.
"""
from __future__ import annotations

import numpy as np

__all__ = ["GrowingState"]


class GrowingState:
    """``x``/``P`` views of capacity-doubling buffers."""

    def __init__(self, n_state: int = 3, capacity: int = 64):
        capacity = max(int(capacity), n_state)
        self.n = int(n_state)
        self._x = np.zeros(capacity)
        self._P = np.zeros((capacity, capacity))

    @property
    def capacity(self) -> int:
        return self._x.shape[0]

    @property
    def x(self) -> np.ndarray:
        return self._x[: self.n]

    @property
    def P(self) -> np.ndarray:
        return self._P[: self.n, : self.n]

    @property
    def buffer(self) -> np.ndarray:
        """The whole C-contiguous covariance buffer (capacity × capacity); P is its [:N, :N]."""
        return self._P

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
        self.n = stop
        return slice(start, stop)

    def remove(self, entries: np.ndarray) -> None:
        """Delete state entries (indices into x) and their rows and columns of P — marginalising them out —, in place, O(N²)."""
        keep = np.setdiff1d(np.arange(self.n), entries)
        m = keep.size
        self._x[:m] = self._x[keep]
        self._P[:m, :m] = self._P[np.ix_(keep, keep)]
        self.n = m
