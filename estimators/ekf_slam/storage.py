"""Growing EKF-SLAM covariance storage: amortised capacity, lower-triangle updates, a deferred low-rank term.

Capacity. The state ``x`` (N,) and covariance ``P`` (N, N) live in preallocated buffers of
size ``capacity ≥ N``; ``x`` and ``P`` are views of the live part. When a new landmark does not
fit, the capacity doubles and the live part is copied once, so adding n landmarks costs O(N²)
copies in total — O(N) amortised per landmark instead of an O(N²) copy each time.

Lower triangle. P is symmetric, and the O(N²) update writes only its lower triangle
(i ≥ j, :func:`.kernels.update_lower`). The stored matrix (:attr:`GrowingState.stored`) is
therefore current in its lower triangle, in the robot rows ``P[0:3, :]`` and in the upper entry
``P[s, s + 1]`` of every landmark block (these O(N) entries are copied after each update, so the
prediction and the association, which read only them, see a current P); the rest of the upper
triangle is copied from the lower one (:func:`.kernels.mirror_lower`, bitwise symmetric) only
when the whole matrix is read (:attr:`GrowingState.P`). Writing the upper half costs about as
much as the rank-20 product itself, and nothing in a filter step needs it.

Deferred update. The covariance is ``P = P_stored + U diag(s) Uᵀ`` with a pending low-rank term
``U`` (N × r, stored as Uᵀ) that :meth:`GrowingState.defer` extends by the columns of one update and
:meth:`GrowingState.flush` applies in one pass over the lower triangle. While a term is
pending, an update needs only a few columns of P, which cost O(N r) (:meth:`GrowingState.columns`;
``filter.py`` derives why this is the sequential update exactly), and the checked entries of P
(:meth:`GrowingState.entries`: the stored P's, read once and kept until the stored P may change — any
access to :attr:`~GrowingState.stored` or :attr:`~GrowingState.P`, which hand out writable views, a flush, a growth or
a removal; :attr:`~GrowingState.view` reads without invalidating, and :meth:`~GrowingState.predict_chain` (the
prediction) keeps them current —, plus the pending term's, kept incrementally). :meth:`GrowingState.correct` checks one
update against them and appends it to the pending term in one compiled call (:func:`.kernels.correct`;
:meth:`GrowingState.correct_run` a run of sequential updates). Entries added while a term
is pending (a new landmark) have zero rows in ``U``: their stored cross-covariances were computed
from the current P, so the earlier terms are already in them.
"""

from __future__ import annotations

import numpy as np

from .checks import Entries, covariance_entries
from .kernels import (
    APPLIED,
    ROBOT_INDEFINITE,
    apply_term,
    batch_innovation,
    correct,
    correct_run,
    gather_columns,
    mirror_lower,
    predict_chain,
)

__all__ = ["GrowingState"]


class GrowingState:
    """``x``/``P`` views of capacity-doubling buffers, P stored as its lower triangle, with a pending low-rank update."""

    def __init__(self, n_state: int = 3, capacity: int = 64):
        capacity = max(int(capacity), n_state)
        self.n = int(n_state)
        self._x = np.zeros(capacity)
        self._P = np.zeros((capacity, capacity))
        self._mirrored = True
        # Uᵀ, (U diag(s))ᵀ and s in rows [:r], kept across sets; the pending term's checked entries (diagonal, robot block,
        # landmark off-diagonals) and the stored P's (valid while _stored_valid)
        self._Ut, self._Ust, self._sg = np.zeros((8, capacity)), np.zeros((8, capacity)), np.zeros(8)
        self._pending = (np.zeros(capacity), np.zeros((3, 3)), np.zeros(capacity // 2))
        self._stored_entries = (np.zeros(capacity), np.zeros((3, 3)), np.zeros(capacity // 2))
        self._stored_valid = False
        self._r = 0

    @property
    def capacity(self) -> int:
        return self._x.shape[0]

    @property
    def x(self) -> np.ndarray:
        return self._x[: self.n]

    @property
    def P(self) -> np.ndarray:
        """The whole current covariance: the pending term applied and the upper triangle copied, if not yet done."""
        self.flush()
        if not self._mirrored:
            mirror_lower(self._P, self.n)
            self._mirrored = True
        self._stored_valid = False
        return self._P[: self.n, : self.n]

    @property
    def stored(self) -> np.ndarray:
        """The stored covariance without the pending term; current in the lower triangle, the robot rows and ``P[s, s + 1]``."""
        self._stored_valid = False
        return self._P[: self.n, : self.n]

    @property
    def view(self) -> np.ndarray:
        """The stored covariance, read-only (:attr:`stored` without invalidating the cached entries)."""
        v = self._P[: self.n, : self.n]
        v.flags.writeable = False
        return v

    def predict_chain(
        self,
        delta: np.ndarray,
        lin: np.ndarray,
        Q_body: np.ndarray,
        Q_world: np.ndarray,
        first_from: np.ndarray,
        shift: np.ndarray,
        commit_indefinite: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """A prediction chain, checked and committed to the robot entries of x and P in one compiled call
        (:func:`.kernels.predict_chain`, which states the arguments and the outcome), keeping the cached entries current;
        no term may be pending. Returns (poses (K + 1, 3), covs (K, 3, 3), D (K, 2), outcome, k)."""
        out = predict_chain(
            self._P, self.n, self._x[: self.n], delta, lin, Q_body, Q_world, first_from, shift, commit_indefinite
        )
        poses, covs, _, outcome, _ = out
        if self._stored_valid and (outcome == APPLIED or (outcome == ROBOT_INDEFINITE and commit_indefinite)):
            sd, sr, _ = self._stored_entries
            sd[:3], sr[:] = np.diagonal(covs[-1]), covs[-1]
        return out

    def _reserve(self, c: int) -> None:
        """Room for c more rows of the pending term."""
        if self._r + c > self._Ut.shape[0]:
            rows = max(2 * self._Ut.shape[0], self._r + c)
            self._Ut, self._Ust = (
                np.concatenate([A, np.zeros((rows - A.shape[0], self.capacity))]) for A in (self._Ut, self._Ust)
            )
            self._sg = np.concatenate([self._sg, np.zeros(rows - self._sg.size)])

    def correct(self, HP: np.ndarray, S: np.ndarray, nu: np.ndarray, joseph: bool) -> tuple[int, float, int, float]:
        """Check one update (HP = (PHᵀ)ᵀ d × N, S d × d, ν d) against the current P's entries and, if it passes, apply
        x += K ν and append its term to the pending one; :func:`.kernels.correct`'s (outcome, NIS, k, value)."""
        c = 3 * nu.size if joseph else nu.size
        self._reserve(c)
        self._refresh_stored_entries()
        out = correct(
            np.ascontiguousarray(HP),
            np.ascontiguousarray(S),
            np.ascontiguousarray(nu, dtype=np.float64),
            joseph,
            self._x[: self.n],
            self._Ut,
            self._Ust,
            self._sg,
            self._r,
            self._pending,
            self._stored_entries,
            3,
        )
        if out[0] == APPLIED:
            self._r += c
        return out

    def correct_run(
        self,
        slots: np.ndarray,
        XL: np.ndarray,
        ML: np.ndarray,
        current: bool,
        Z: np.ndarray,
        R: np.ndarray,
        joseph: bool,
    ) -> tuple[int, int, int, float, np.ndarray, np.ndarray, np.ndarray]:
        """Sequential updates with range-bearing observations Z (k, 2) (noise R (k, 2, 2)) of landmark slots (k,), H at
        (XL[j], ML[j]) or at the current estimate, until one is not applied; one compiled call (:func:`.kernels.correct_run`:
        O(N (r + 1)) per row plus O(N k²) for the run in the standard form, O(N (r + j)) for row j row by row). Returns q
        (rows applied), (outcome, k, value) of row q if q < k, the applied rows' NIS (q,) and Jacobians [H_x, H_m]
        (q, 2, 5), and S of row q."""
        self._reserve((6 if joseph else 2) * slots.size)
        self._refresh_stored_entries()
        q, self._r, outcome, k, value, nis, H, S = correct_run(
            self._P,
            self.n,
            self._Ut,
            self._Ust,
            self._sg,
            self._r,
            self._pending,
            self._stored_entries,
            self._x[: self.n],
            slots,
            XL,
            ML,
            current,
            Z,
            R,
            joseph,
            3,
        )
        return q, outcome, k, value, nis, H, S

    def batch_innovation(
        self, slots: np.ndarray, XL: np.ndarray, ML: np.ndarray, current: bool, Z: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """HP (2m, N), S (2m, 2m) and ν (2m,) of m observations Z (m, 2) of landmark slots (m,) taken together, from the
        current P (:func:`.kernels.batch_innovation`), O(N m (r + 1))."""
        return batch_innovation(
            self._P, self.n, self._Ut, self._Ust, self._r, 3 + 2 * slots, XL, ML, current, self._x[: self.n], Z, R
        )

    def columns(self, idx) -> np.ndarray:
        """The current ``P[:, idx]`` (N × len(idx)) from the stored P and the pending term, O(N (len(idx) + r)).

        Read from what is current in the stored P (:func:`.kernels.gather_columns`: a robot column is a robot row, a
        landmark column its row left of the diagonal and the lower triangle below), each distinct column once.
        """
        n = self.n
        cols, where = np.unique(np.asarray(idx, dtype=np.int64), return_inverse=True)
        out = gather_columns(self._P, n, cols)
        if self._r:
            out += self._Ust[: self._r, :n].T @ self._Ut[: self._r, cols]
        return out[:, where]

    def rows(self, idx) -> np.ndarray:
        """The current ``P[idx, :]``."""
        return self.columns(idx).T

    def _refresh_stored_entries(self) -> None:
        """Read the stored P's checked entries into their cache if the stored P may have changed since, O(N)."""
        if not self._stored_valid:
            n = self.n
            d, robot, off = covariance_entries(self._P[:n, :n])
            sd, sr, so = self._stored_entries
            sd[:n], sr[:], so[: off.size] = d, robot, off
            self._stored_valid = True

    def entries(self) -> Entries:
        """The checked entries (:mod:`.checks`) of the current P: the stored P's (cached) plus the pending term's, O(N)."""
        self._refresh_stored_entries()
        n, m = self.n, (self.n - 3) // 2
        (sd, sr, so), (pd, pr, po) = self._stored_entries, self._pending
        return sd[:n] + pd[:n], sr + pr, so[:m] + po[:m]

    def flush(self) -> None:
        """Apply the pending term to the lower triangle (one pass), to the robot rows and the landmark blocks' upper entries
        and to the cached checked entries, and clear it (one compiled call, :func:`.kernels.apply_term`)."""
        if not self._r:
            return
        apply_term(
            self._P,
            self.n,
            self._Ut,
            self._Ust,
            self._sg,
            self._r,
            self._pending,
            self._stored_entries,
            self._stored_valid,
        )
        self._mirrored = False
        self._r = 0

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
            self._Ut, self._Ust = (
                np.concatenate([A, np.zeros((A.shape[0], capacity - A.shape[1]))], axis=1)
                for A in (self._Ut, self._Ust)
            )
            self._pending = tuple(
                np.concatenate([a, np.zeros(k - a.size)]) if a.ndim == 1 else a
                for a, k in zip(self._pending, (capacity, 0, capacity // 2))
            )
            self._stored_entries = (np.zeros(capacity), np.zeros((3, 3)), np.zeros(capacity // 2))
        self._stored_valid = False
        self._x[start:stop] = 0.0
        self._P[start:stop, :stop] = 0.0
        self._P[:stop, start:stop] = 0.0
        self._Ut[:, start:stop] = self._Ust[:, start:stop] = 0.0
        self.n = stop
        return slice(start, stop)

    def remove(self, entries: np.ndarray) -> None:
        """Delete state entries (indices into x) and their rows and columns of P — marginalising them out —, in place, O(N²).
        A pending deferred update is applied first (the kept block of P must be the current one)."""
        self.flush()
        keep = np.setdiff1d(np.arange(self.n), entries)
        m = keep.size
        self._x[:m] = self._x[keep]
        self._P[:m, :m] = self._P[np.ix_(keep, keep)]
        self._stored_valid = False
        self.n = m
