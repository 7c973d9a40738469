"""Replaying motion input between the observation events of a ``Sequence``: the filters' one event loop.

Filters walk ``sequence.events()`` in time order. Before applying an event at time ``t`` they
propagate from their current time to ``t`` with the motion input in force:

* :class:`Twist` input is piecewise constant: row k applies ``(v_k, ω_k)`` on
  ``[t_k, t_k + dt_k)``; outside every interval the robot is taken to stand still.
  :func:`twist_pieces` cuts ``(t_from, t_to]`` into ``(v, ω, dt)`` pieces, vectorised.
* :class:`Increments` input is applied as a whole at its stamp (it is the motion since the
  previous stamp), so a filter treats an ``Increments`` row as a motion event.

:func:`blocks` cuts the time-ordered events into :class:`Block` s — the motion events up to an observation event (the
motion *chain*), that observation event, and the interval ``(t0, t1]`` the chain's motion carries the filter over —
and gives each block its :class:`Motion`: the pieces (twists) or rows (increments) to apply, one entry per piece, with
where each motion event's stamp falls among them. A driver then reads as named steps: predict the block's motion,
record the poses at the chain's stamps, apply the observation, record the posterior.

Bad rows are skipped and counted here, so that one corrupt row never aborts a run (:data:`LIMITS`): a motion row with
a non-finite value or a value beyond the physical range is not applied (the robot stands still during a skipped twist
row; ``Motion.rejected``); a range-bearing row whose finite range is beyond ``LIMITS.range`` is left out of its set
(:func:`observation_rows`; the filter counts the non-finite rows and negative ranges it is given).

A filter records a pose after every event; events of several streams can share a stamp (a motion
row and an observation set at the same time). :func:`last_per_stamp` keeps one pose per stamp, the
last one recorded there — the posterior after everything that happened at that time — so that
every written trajectory has strictly increasing stamps (as evo and the TUM format expect).

``CLOCKS`` are the clocks an estimator's ``step_clock`` parameter names for ``Estimate.step_time``:
wall time, or the process's CPU time (all threads), which other processes on a shared machine
disturb less (cost studies and benchmarks use it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np

from slamarena.datasets.sequence import Event, Increments, Sequence, Twist

__all__ = [
    "twist_pieces",
    "last_per_stamp",
    "CLOCKS",
    "StepClock",
    "Limits",
    "LIMITS",
    "Motion",
    "Block",
    "blocks",
    "observation_rows",
]

#: ``step_clock`` → the clock of ``Estimate.step_time``
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
StepClock = Literal["wall", "cpu"]


@dataclass(frozen=True)
class Limits:
    """The physical range of an input row: a finite value beyond it is a corrupt row, not a measurement.

    Far beyond every sensor and robot the project reads (lidars and landmark sensors reach ≤ ~300 m, robots move at
    ≤ ~30 m/s), and far below where a filter's covariance stops being representable (a range of 1e20 m makes
    EKF-SLAM's new-landmark covariance ~1e36 m², which cancels to an indefinite innovation covariance)."""

    range: float = 1e4  # m, range-bearing range
    speed: float = 1e2  # m/s, |v| of a twist
    turn_rate: float = 1e2  # rad/s, |ω| of a twist
    step: float = 1e4  # m, |δx|, |δy| of an odometry increment; rad, |δθ|


LIMITS = Limits()


def twist_pieces(twist: Twist, t_from: float, t_to: float, with_rows: bool = False) -> tuple[np.ndarray, ...]:
    """The ``(v, ω, dt)`` pieces (arrays) that carry the state from ``t_from`` to ``t_to``.

    Pieces with zero length are dropped; time where no command is in force yields no piece
    (standing still needs no prediction). ``t_to < t_from`` is an error. With
    ``with_rows=True`` a fourth array gives the Twist row of each piece (e.g. to scale
    per-row noise to the part of the row a piece covers).
    """
    if t_to < t_from:
        raise ValueError(f"cannot propagate backwards in time: {t_from!r} → {t_to!r}")
    if t_to == t_from or not len(twist):
        empty = np.zeros(0)
        return (empty, empty, empty, empty.astype(np.int64)) if with_rows else (empty, empty, empty)
    starts, ends = twist.t, twist.t + twist.dt
    first = max(int(np.searchsorted(starts, t_from, side="right")) - 1, 0)
    last = int(np.searchsorted(starts, t_to, side="left"))
    k = np.arange(first, last)
    lo = np.maximum(starts[k], t_from)
    hi = np.minimum(ends[k], t_to)
    keep = hi > lo
    k, lo, hi = k[keep], lo[keep], hi[keep]
    if with_rows:
        return twist.v[k], twist.omega[k], hi - lo, k
    return twist.v[k], twist.omega[k], hi - lo


@dataclass(frozen=True)
class Motion:
    """The motion that carries a filter over one block: P pieces, each a Twist piece or an Increments row.

    ``rows`` (P,) the motion stream's row of each piece; ``start`` (P,) where each piece begins [s] (a twist piece: its
    row's stamp or the block's start; an increment: the previous row's stamp, −∞ for the first row); ``end`` (P,)
    where it ends [s] (an increment: its stamp); ``at_event`` (E,) how many pieces have moved the robot by the stamp
    of each of the chain's E motion events (a twist row moves the robot from its stamp on, an increment has moved it
    by its stamp); ``rejected`` the rows skipped (non-finite or beyond :data:`LIMITS`). Twists: ``v``, ``omega``,
    ``dt`` (P,); increments: ``delta`` (P, 3) and ``cov`` (P, 3, 3) or None (the filter's own covariance).
    """

    kind: Literal["twist", "increments", "none"]
    rows: np.ndarray
    start: np.ndarray
    end: np.ndarray
    at_event: np.ndarray
    rejected: int = 0
    v: np.ndarray | None = None
    omega: np.ndarray | None = None
    dt: np.ndarray | None = None
    delta: np.ndarray | None = None
    cov: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.rows)

    def predict(self, filt, a: int = 0, b: int | None = None, **kwargs) -> tuple[np.ndarray, np.ndarray]:
        """Apply pieces ``a:b`` with the filter's chain prediction (``predict_twists`` / ``predict_increments``);
        its (poses, covariances) — empty when there is no motion input (the robot stands still)."""
        if self.kind == "twist":
            return filt.predict_twists(self.v[a:b], self.omega[a:b], self.dt[a:b], **kwargs)
        if self.kind == "increments":
            return filt.predict_increments(self.delta[a:b], None if self.cov is None else self.cov[a:b], **kwargs)
        return np.zeros((0, 3)), np.zeros((0, 3, 3))


@dataclass(frozen=True)
class Block:
    """The motion events ``chain`` up to the observation event ``observation`` (None after the last one), the
    interval ``(t0, t1]`` their motion covers, and that motion (computed on first use)."""

    chain: list[Event]
    observation: Event | None
    t0: float
    t1: float
    _sequence: Sequence = field(repr=False)
    _row_cov: bool = field(repr=False, default=True)

    @cached_property
    def motion(self) -> Motion:
        return _motion(self._sequence.motion, self.chain, self.t0, self.t1, self._row_cov)


def blocks(sequence: Sequence, observe: tuple[str, ...] = ("range_bearing",), row_cov: bool = True) -> list[Block]:
    """The motion and ``observe`` events of ``sequence`` in time order, cut into blocks that each end at an observation
    event (the last block may have none). ``row_cov``: whether increments carry ``Increments.cov`` (False: the
    filter's own covariance, e.g. an ``increment_cov`` parameter)."""
    table = [e for e in sequence.events() if e.stream == "motion" or e.stream in observe]
    out, i, t_now = [], 0, sequence.t0
    while i < len(table):
        j = i
        while j < len(table) and table[j].stream == "motion":
            j += 1
        t_end = table[j].t if j < len(table) else (table[j - 1].t if j > i else t_now)
        out.append(Block(table[i:j], table[j] if j < len(table) else None, t_now, t_end, sequence, row_cov))
        t_now, i = t_end, j + 1
    return out


def _motion(motion, chain: list[Event], t0: float, t1: float, row_cov: bool) -> Motion:
    empty = np.zeros(0, dtype=np.int64)
    if isinstance(motion, Twist):
        v, w, dt, rows = twist_pieces(motion, t0, t1, with_rows=True)
        ok = np.isfinite(v) & np.isfinite(w) & (np.abs(v) <= LIMITS.speed) & (np.abs(w) <= LIMITS.turn_rate)
        v, w, dt, rows = v[ok], w[ok], dt[ok], rows[ok]
        start, end = np.maximum(motion.t[rows], t0), np.minimum(motion.t[rows] + motion.dt[rows], t1)
        at_event = np.searchsorted(rows, [event.start for event in chain]).astype(np.int64)
        return Motion("twist", rows, start, end, at_event, int((~ok).sum()), v=v, omega=w, dt=dt)
    if isinstance(motion, Increments):
        rows = np.arange(chain[0].start, chain[-1].stop) if chain else empty
        delta = motion.delta[rows]
        ok = np.all(np.isfinite(delta), axis=1) & np.all(np.abs(delta) <= LIMITS.step, axis=1)
        if row_cov and motion.cov is not None:  # a row's own covariance, when it is used, must be finite too
            ok &= np.all(np.isfinite(motion.cov[rows]), axis=(1, 2))
        rows = rows[ok]
        cov = motion.cov[rows] if row_cov and motion.cov is not None else None
        at_event = np.searchsorted(rows, [event.stop for event in chain]).astype(np.int64)
        start = np.r_[-np.inf, motion.t][rows]
        return Motion("increments", rows, start, motion.t[rows], at_event, int((~ok).sum()), delta=delta[ok], cov=cov)
    return Motion("none", empty, np.zeros(0), np.zeros(0), np.zeros(len(chain), dtype=np.int64))


def observation_rows(event: Event, ranges: np.ndarray) -> tuple[np.ndarray, int]:
    """The rows of observation event ``event`` whose range is not beyond ``LIMITS.range`` (non-finite rows are kept:
    the filter counts them) and how many were left out."""
    rows = np.arange(event.start, event.stop)
    keep = ~(ranges[rows] > LIMITS.range)
    return rows[keep], int((~keep).sum())


def last_per_stamp(t: np.ndarray, step_time: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Keep the last record of every stamp: ``(t, step_time, *arrays)`` with strictly increasing t.

    ``t`` (K,) non-decreasing; each array has K rows. A kept record's step time is the sum of the
    step times of the records it replaces (the work done at that stamp).
    """
    t = np.asarray(t, dtype=float)
    if t.size and np.any(np.diff(t) < 0):
        raise ValueError("last_per_stamp: the stamps must be non-decreasing")
    last = np.flatnonzero(np.append(np.diff(t) > 0, True)) if t.size else np.zeros(0, dtype=int)
    first = np.concatenate([[0], last[:-1] + 1]) if t.size else last
    steps = np.add.reduceat(np.asarray(step_time, dtype=float), first) if t.size else np.zeros(0)
    return (t[last], steps, *(np.asarray(a)[last] for a in arrays))
