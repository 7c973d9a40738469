"""Planar kinematics of a velocity-driven robot: the body-frame increment of (v, ω) held for dt.

Two models, the same as :mod:`slamarena.estimators.models` (which adds their Jacobians and uses this
module for the motion itself, so simulators and estimators share one implementation)::

    euler: δ = (v dt, 0, ω dt)                       the notes' first-order step
    arc:   δ = exp((v dt, 0, ω dt)) in SE(2)         the exact constant-twist motion
             = (v dt sin φ/φ, v dt (1 − cos φ)/φ, φ),  φ = ω dt (smooth through φ = 0)

A pose moves as ``x' = x ⊕ δ``.

An Ackerman (car-like) vehicle moves its rear axle centre as such a robot: with wheel base L and steering angle α
(of the virtual front wheel at the centre line), ``ω = v tan α / L``. A speed measured by an encoder on a rear wheel
at lateral offset h from the centre line (h > 0: the left wheel) is that wheel's, ``v_e = v (1 − h tan α / L)``
(the inner wheel of a left turn is slower), so the axle centre's twist is (:func:`ackerman_twist`)::

    v = v_e / (1 − h tan α / L),      ω = v tan α / L

(Guivant & Nebot's model, research/method/carpark.md; its Jacobians are in :mod:`slamarena.estimators.models`).
"""

from __future__ import annotations

from typing import Literal, get_args

import numpy as np

from .geometry import accumulate, se2_exp

__all__ = ["MotionModel", "MODELS", "increment", "integrate", "ackerman_twist"]

#: the motion models' names (a parameter's type)
MotionModel = Literal["euler", "arc"]
MODELS = get_args(MotionModel)


def increment(model: str, v, omega, dt) -> np.ndarray:
    """Body-frame increment δ (..., 3) of the velocities ``(v, omega)`` held for ``dt``."""
    if model not in MODELS:
        raise ValueError(f"unknown motion model {model!r}; choose from {MODELS}")
    v, omega, dt = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (v, omega, dt)))
    twist = np.stack([v * dt, np.zeros_like(v), omega * dt], axis=-1)
    return twist if model == "euler" else se2_exp(twist)


def integrate(model: str, start, v, omega, dt) -> np.ndarray:
    """Poses (K + 1, 3) from ``start`` through K velocity rows, vectorised (dead reckoning)."""
    return accumulate(start, increment(model, v, omega, dt))


def ackerman_twist(speed, steering, wheelbase: float, encoder_offset: float) -> tuple[np.ndarray, np.ndarray]:
    """The rear axle centre's ``(v, ω)`` of an Ackerman vehicle from the encoder wheel's speed [m/s] and the steering
    angle [rad] (module docstring); ``wheelbase`` L [m], ``encoder_offset`` h [m] (left of the centre line > 0)."""
    speed, steering = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(steering, dtype=float))
    tan = np.tan(steering)
    v = speed / (1.0 - encoder_offset * tan / wheelbase)
    return v, v * tan / wheelbase
