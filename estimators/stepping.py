"""Replaying motion input between the events of a ``Sequence``.

Filters walk ``sequence.events()`` in time order. Before applying an event at time ``t`` they
propagate from their current time to ``t`` with the motion input in force:

* :class:`Twist` input is piecewise constant: row k applies ``(v_k, ω_k)`` on
  ``[t_k, t_k + dt_k)``; outside every interval the robot is taken to stand still.
  :func:`twist_pieces` cuts ``(t_from, t_to]`` into ``(v, ω, dt)`` pieces, vectorised.
* :class:`Increments` input is applied as a whole at its stamp (it is the motion since the
  previous stamp), so a filter treats an ``Increments`` row as a motion event.
"""
from __future__ import annotations

import numpy as np

from slamarena.datasets.sequence import Twist

__all__ = ["twist_pieces"]


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
