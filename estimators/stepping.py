"""Replaying motion input between the events of a ``Sequence``.

Filters walk ``sequence.events()`` in time order. Before applying an event at time ``t`` they
propagate from their current time to ``t`` with the motion input in force:

* :class:`Twist` input is piecewise constant: row k applies ``(v_k, ω_k)`` on
  ``[t_k, t_k + dt_k)``; outside every interval the robot is taken to stand still.
  :func:`twist_pieces` cuts ``(t_from, t_to]`` into ``(v, ω, dt)`` pieces, vectorised.
* :class:`Increments` input is applied as a whole at its stamp (it is the motion since the
  previous stamp), so a filter treats an ``Increments`` row as a motion event.

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
from typing import Literal

import numpy as np

from slamarena.datasets.sequence import Twist

__all__ = ["twist_pieces", "last_per_stamp", "CLOCKS", "StepClock"]

#: ``step_clock`` → the clock of ``Estimate.step_time``
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
StepClock = Literal["wall", "cpu"]


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
