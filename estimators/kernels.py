"""Compiled (numba) pieces of the range-bearing observation model that several estimators' kernels share.

``range_bearing(x, m, zhat, H_x, H_m)`` writes, for robot pose x = (x, y, θ) (3,) and landmark m (2,), the predicted
observation and its Jacobians (the model of :mod:`slamarena.estimators.models`, written out for compiled loops)::

    δ = m − p, q = δᵀδ, r = √q
    ẑ = (r, wrap(atan2(δ_y, δ_x) − θ))                         (2,)
    H_m = [[δ_x/r, δ_y/r], [−δ_y/q, δ_x/q]]                    (2, 2)
    H_x = [[−δ_x/r, −δ_y/r, 0], [δ_y/q, −δ_x/q, −1]]           (2, 3)

``wrap(a)`` maps an angle to [−π, π) (the numpy :func:`~slamarena.datasets.geometry.wrap_angle` maps to (−π, π];
the two differ only at ±π).
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["wrap", "range_bearing"]


@njit(cache=True)
def wrap(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def range_bearing(x, m, zhat, Hx, Hm):
    dx = m[0] - x[0]
    dy = m[1] - x[1]
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    zhat[0] = r
    zhat[1] = wrap(math.atan2(dy, dx) - x[2])
    Hm[0, 0] = dx / r
    Hm[0, 1] = dy / r
    Hm[1, 0] = -dy / q
    Hm[1, 1] = dx / q
    Hx[0, 0] = -Hm[0, 0]
    Hx[0, 1] = -Hm[0, 1]
    Hx[0, 2] = 0.0
    Hx[1, 0] = -Hm[1, 0]
    Hx[1, 1] = -Hm[1, 1]
    Hx[1, 2] = -1.0
