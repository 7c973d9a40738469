"""Compiled (numba) pieces of the range-bearing observation model that several estimators' kernels share.

``range_bearing(x, m, zhat, H_x, H_m)`` writes, for robot pose x = (x, y, θ) (3,) and landmark m (2,), the predicted
observation and its Jacobians (the model of :mod:`slamarena.estimators.models`, written out for compiled loops)::

    δ = m − p, q = δᵀδ, r = √q
    ẑ = (r, wrap(atan2(δ_y, δ_x) − θ))                         (2,)
    H_m = [[δ_x/r, δ_y/r], [−δ_y/q, δ_x/q]]                    (2, 2)
    H_x = [[−δ_x/r, −δ_y/r, 0], [δ_y/q, −δ_x/q, −1]]           (2, 3)

``wrap(a)`` maps an angle to (−π, π], the project's one convention: the compiled
:func:`~slamarena.datasets.geometry.wrap_scalar`, the formula of the numpy ``wrap_angle``, so the two agree bit for bit.

``twist_motion(v, ω, dt, arc, M)`` is the velocity motion model of :mod:`slamarena.estimators.models` (``EULER`` or
``ARC``), written out the same way for a prediction's compiled path: for K rows (v_k, ω_k, dt_k) the body-frame
increment δ_k (K, 3) and the body-frame control noise ``Q_k = V_k M V_kᵀ`` (K, 3, 3), V_k = ∂δ/∂(v, ω) (3, 2) at
θ = 0, M (2, 2) the covariance of (v, ω). With φ = ω dt, a = φ/2, s(a) = sin a / a::

    euler: δ = (v dt, 0, φ)                               V = [[dt, 0], [0, 0], [0, dt]]
    arc:   δ = (v dt sin φ/φ, v dt (1 − cos φ)/φ, φ)       V = [[dt s cos a, ½ v dt² (s′ cos a − s sin a)],
                                                                [dt s sin a, ½ v dt² (s′ sin a + s cos a)],
                                                                [0,          dt                       ]]

(the same series below |φ| < 1e-9 and |a| < 1e-4 as the numpy forms; as theirs, the arc's δ heading is wrapped to
(−π, π] and Euler's is not).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from slamarena.datasets.geometry import wrap_scalar

__all__ = ["wrap", "range_bearing", "twist_motion"]


#: the angle a wrapped to (−π, π], compiled: :func:`~slamarena.datasets.geometry.wrap_scalar`
wrap = njit(cache=True)(wrap_scalar)


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


@njit(cache=True)
def twist_motion(v, omega, dt, arc, M):
    K = v.shape[0]
    delta = np.empty((K, 3))
    Q = np.empty((K, 3, 3))
    V = np.zeros((3, 2))
    for k in range(K):
        vdt, phi, h = v[k] * dt[k], omega[k] * dt[k], dt[k]
        V[:] = 0.0
        V[2, 1] = h
        if arc:
            if abs(phi) < 1e-9:
                sx, sy = 1.0 - phi * phi / 6.0, 0.5 * phi
            else:
                sx, sy = math.sin(phi) / phi, (1.0 - math.cos(phi)) / phi
            delta[k, 0], delta[k, 1], delta[k, 2] = sx * vdt, sy * vdt, wrap(phi)
            a = 0.5 * phi
            if a == 0.0:
                sa = 1.0
            else:
                sa = math.sin(a) / a
            if abs(a) < 1e-4:
                dsa = -a / 3.0 + a**3 / 30.0
            else:
                dsa = (a * math.cos(a) - math.sin(a)) / (a * a)
            c, s = math.cos(a), math.sin(a)
            V[0, 0], V[1, 0] = h * sa * c, h * sa * s
            V[0, 1] = vdt * (dsa * c - sa * s) * 0.5 * h
            V[1, 1] = vdt * (dsa * s + sa * c) * 0.5 * h
        else:
            delta[k, 0], delta[k, 1], delta[k, 2] = vdt, 0.0, phi
            V[0, 0] = h
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for i in range(2):
                    for j in range(2):
                        acc += V[a, i] * M[i, j] * V[b, j]
                Q[k, a, b] = acc
    return delta, Q
