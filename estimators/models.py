"""Motion and observation models with analytic Jacobians, shared by every estimator and simulator.

Robot state ``x = (x, y, θ)``; control ``u = (v, ω)`` held for ``dt``.

Euler model (the EKF-SLAM matrix-dimensions reference, the technical notes, the localizer notes)::

    x' = x + v cosθ dt      G = ∂x'/∂x = [[1, 0, −v sinθ dt],     V = ∂x'/∂u = [[cosθ dt, 0],
    y' = y + v sinθ dt                    [0, 1,  v cosθ dt],                   [sinθ dt, 0],
    θ' = θ + ω dt                         [0, 0,  1        ]]                   [0,      dt]]

Exact arc model (the lecture notes' "with rotation", sign of the y row corrected — see
``research/method/ekf_slam.md``). With φ = ω dt, a = φ/2 and s(a) = sin(a)/a (s(0) = 1)::

    x' = x + v dt s(a) cos(θ + a)       ( = x − (v/ω) sinθ + (v/ω) sin(θ + φ) for ω ≠ 0 )
    y' = y + v dt s(a) sin(θ + a)       ( = y + (v/ω) cosθ − (v/ω) cos(θ + φ) for ω ≠ 0 )
    θ' = θ + φ

This form is smooth through ω = 0, where it becomes the Euler step, so no special case is
needed. Both models are "compose the pose with a body-frame increment":
``x' = x ⊕ δ(u, dt)``, with δ = (v dt, 0, ω dt) for Euler and
δ = (v dt s(a) cos a, v dt s(a) sin a, φ) for the arc.

Range-bearing observation of landmark m = (mx, my), with δx = mx − x, δy = my − y, q = δx² + δy²::

    h = [√q, atan2(δy, δx) − θ]
    H_x = [[−δx/√q, −δy/√q,  0],      H_m = [[ δx/√q, δy/√q],
           [ δy/q,  −δx/q,  −1]]             [−δy/q,  δx/q ]]

Inverse observation (landmark initialisation) from z = (r, b)::

    m = [x + r cos(θ + b), y + r sin(θ + b)]
    ∂m/∂x = [[1, 0, −r sin(θ + b)], [0, 1, r cos(θ + b)]]      ∂m/∂z = [[cos(θ+b), −r sin(θ+b)], [sin(θ+b), r cos(θ+b)]]

Observation noise (:func:`observation_covariances`): the stated R (2, 2) for every observation (polar), or, for a sensor
whose noise is isotropic σ² I in the plane (cartesian, σ² = R[0, 0]), ``R_j = diag(σ², σ²/r_j²)`` at range r_j.

The noise in force (:func:`noise_in_force`): the method's parameter if given, else the noise the sequence states
(``Sequence.noise``), else the method's default. A χ² gate (:func:`chi2_gate`): the d² below which a dof-dimensional
innovation is accepted with probability ``confidence``.

Odometry-increment motion x' = x ⊕ δ has ∂x'/∂x = [[1, 0, −s δx − c δy], [0, 1, c δx − s δy], [0, 0, 1]]
and ∂x'/∂δ = blockdiag(R(θ), 1) (:func:`compose_jacobians`).

Ackerman vehicle (:class:`AckermanModel`; Guivant & Nebot, the ACFR vehicles): wheel base L, speed v_e measured on the
rear wheel at lateral offset h, steering angle α; the rear axle centre moves with the twist
(:func:`slamarena.datasets.kinematics.ackerman_twist`) ``v = v_e / (1 − h tan α / L)``, ``ω = v tan α / L``, whose
Jacobian with D = 1 − h tan α / L, T = tan α is::

    ∂(v, ω)/∂(v_e, α) = [[1/D,        v_e h sec²α / (L D²)           ],
                          [T/(L D),    (T ∂v/∂α + v sec²α) / L        ]]

A sensor at (a, b) in the axle frame, with pose (x, y, φ) (the sensor's position, the vehicle's heading), moves as::

    ẋ = v cos φ − ω (a sin φ + b cos φ),   ẏ = v sin φ + ω (a cos φ − b sin φ),   φ̇ = ω

Euler step x' = x + f(x, u) dt (the dataset's model), G = I + dt ∂f/∂x with ∂ẋ/∂φ = −v sin φ − ω (a cos φ − b sin φ),
∂ẏ/∂φ = v cos φ − ω (a sin φ + b cos φ); V = dt ∂f/∂(v, ω) · ∂(v, ω)/∂(v_e, α) with ∂f/∂v = (cos φ, sin φ, 0),
∂f/∂ω = (−(a sin φ + b cos φ), a cos φ − b sin φ, 1).

All functions broadcast over leading axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Annotated

import numpy as np
from pydantic import Field, PositiveFloat
from scipy.special import gammaincinv

from slamarena.datasets import kinematics
from slamarena.datasets.geometry import accumulate, compose, wrap_angle

__all__ = [
    "MotionModel",
    "EULER",
    "ARC",
    "MOTION_MODELS",
    "AckermanModel",
    "observe",
    "observation_jacobians",
    "inverse_observe",
    "inverse_observation_jacobians",
    "compose_jacobians",
    "propagate_covariance",
    "compose_chain",
    "UNSTATED_TWIST_COV",
    "TwistPeriod",
    "twist_increment_cov",
    "DEFAULT_RANGE_BEARING_COV",
    "RangeBearingNoise",
    "observation_covariances",
    "noise_in_force",
    "chi2_gate",
]

#: M, the twist noise of the landmark-SLAM filters (EKF-SLAM, FastSLAM) when neither the method's parameters nor the
#: sequence state one: MRCLAM's, identified against Vicon (experiments/configs/mrclam.yaml; σ_v 0.108 m/s, σ_ω 0.417 rad/s
#: per (v, ω) row) — chosen there, never on the data it is scored on (the car park states none:
#: research/notebook/2026-11-28-ekf-defaults.md). The former σ_v 0.1, σ_ω 0.05 locks EKF-SLAM without ids out where the
#: car park returns to its start.
UNSTATED_TWIST_COV = np.diag([0.0117624, 0.174])
#: R when neither the parameters nor the sequence state one: σ_r = 0.1 m, σ_b = 1°
DEFAULT_RANGE_BEARING_COV = np.diag([0.1**2, np.radians(1.0) ** 2])


def noise_in_force(parameter, sequence, name: str, default=None, required: bool = False) -> np.ndarray | None:
    """The noise ``name`` (a :class:`~slamarena.datasets.sequence.Noise` field) a method uses on ``sequence``: the
    method's ``parameter`` if given, else the noise the sequence states, else ``default`` (as a float array; None if
    none of them). ``required``: ValueError naming the sequence and the parameter to pass instead of None."""
    value = parameter if parameter is not None else getattr(getattr(sequence, "noise", None), name, None)
    value = default if value is None else value
    if value is None:
        if required:
            raise ValueError(f"{getattr(sequence, 'name', 'the sequence')}: no {name} stated; pass {name}=...")
        return None
    return np.asarray(value, dtype=float)


#: the ``twist_period`` parameter of the landmark filters (EKF-SLAM, FastSLAM): T of :func:`twist_increment_cov`
TwistPeriod = Annotated[
    PositiveFloat | None,
    Field(
        description="the row period T [s] the twist covariance M is stated for: a row held for dt is applied with M·T/dt "
        "(a white velocity error of density M·T), so a stretch's pose error depends on its duration, not on how its rows "
        "are cut; None: M for every row whatever its dt (the simulators' convention, the same for rows of period T)"
    ),
]


def twist_increment_cov(row_cov: np.ndarray, dt: np.ndarray, period: float | None) -> np.ndarray:
    """The covariance of the increments of twist rows (v_k, ω_k) held for dt_k (K,), from ``row_cov`` = V_k M V_kᵀ
    (K, 3, 3) (V_k = ∂δ/∂u (3, 2), M the twist covariance (2, 2)), under the twist-noise convention ``period``:

        C_k = V_k M V_kᵀ              period None: M is the covariance of every row, whatever its dt
        C_k = (T / dt_k) V_k M V_kᵀ   period T: M is stated for rows of period T, i.e. a white velocity error of
                                      density M T, so a stretch's pose error depends on its duration, not its cut

    (for rows of period T the two agree; V ≈ dt ∂δ/∂(u dt), so C_k ≈ dt_k T (∂δ/∂(u dt)) M (·)ᵀ grows with dt_k
    linearly, as a random walk). The one convention of EKF-SLAM and FastSLAM; ``row_cov`` itself for period None."""
    if period is None:
        return row_cov
    return (period / np.asarray(dt, dtype=float))[:, None, None] * row_cov


def chi2_gate(confidence: float | None, dof: int) -> float:
    """The χ² quantile P(χ²_dof < gate) = confidence: the gate of a d² (NIS, Mahalanobis) of dimension ``dof``;
    ∞ (no gate) for ``confidence`` None or 1."""
    if confidence is None or confidence == 1.0:
        return math.inf
    return float(2.0 * gammaincinv(0.5 * dof, confidence))


def _sinc(a: np.ndarray) -> np.ndarray:
    """sin(a)/a with the limit 1 at a = 0."""
    return np.sinc(a / np.pi)


def _dsinc(a: np.ndarray) -> np.ndarray:
    """d/da [sin(a)/a], with its series near 0."""
    small = np.abs(a) < 1e-4
    a_safe = np.where(small, 1.0, a)
    return np.where(small, -a / 3.0 + a**3 / 30.0, (a_safe * np.cos(a_safe) - np.sin(a_safe)) / a_safe**2)


@dataclass(frozen=True)
class MotionModel:
    """A velocity motion model: ``predict``, body-frame ``increment`` and Jacobians ``G``, ``V``."""

    name: str

    def increment(self, v, omega, dt) -> np.ndarray:
        """Body-frame pose increment δ(u, dt), shape ``(..., 3)`` (:mod:`slamarena.datasets.kinematics`)."""
        return kinematics.increment(self.name, v, omega, dt)

    def predict(self, x, v, omega, dt) -> np.ndarray:
        """x' = x ⊕ δ(u, dt) (heading wrapped)."""
        return compose(np.asarray(x, dtype=float), self.increment(v, omega, dt))

    def integrate(self, start, v, omega, dt) -> np.ndarray:
        """Dead reckoning of a whole control sequence: (K + 1, 3) poses, vectorised."""
        return kinematics.integrate(self.name, start, v, omega, dt)

    def jacobians(self, x, v, omega, dt) -> tuple[np.ndarray, np.ndarray]:
        """G = ∂x'/∂x (..., 3, 3) and V = ∂x'/∂(v, ω) (..., 3, 2) at (x, u)."""
        x = np.asarray(x, dtype=float)
        th = x[..., 2]
        v, omega, dt, th = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (v, omega, dt, th)))
        shape = th.shape
        G = np.zeros(shape + (3, 3))
        V = np.zeros(shape + (3, 2))
        G[..., 0, 0] = G[..., 1, 1] = G[..., 2, 2] = 1.0
        V[..., 2, 1] = dt
        if self.name == "euler":
            c, s = np.cos(th), np.sin(th)
            G[..., 0, 2] = -v * s * dt
            G[..., 1, 2] = v * c * dt
            V[..., 0, 0] = c * dt
            V[..., 1, 0] = s * dt
            return G, V
        a = 0.5 * omega * dt
        sa, dsa = _sinc(a), _dsinc(a)
        c, s = np.cos(th + a), np.sin(th + a)
        G[..., 0, 2] = -v * dt * sa * s
        G[..., 1, 2] = v * dt * sa * c
        V[..., 0, 0] = dt * sa * c
        V[..., 1, 0] = dt * sa * s
        V[..., 0, 1] = v * dt * (dsa * c - sa * s) * 0.5 * dt
        V[..., 1, 1] = v * dt * (dsa * s + sa * c) * 0.5 * dt
        return G, V


EULER = MotionModel("euler")
ARC = MotionModel("arc")
MOTION_MODELS: dict[str, MotionModel] = {"euler": EULER, "arc": ARC}


@dataclass(frozen=True)
class AckermanModel:
    """An Ackerman vehicle driven by (encoder speed v_e [m/s], steering α [rad]) (module docstring): ``wheelbase`` L,
    ``encoder_offset`` h (the encoder wheel left of the centre line > 0), a sensor at ``mount`` (a, b) [m] ahead of and
    left of the rear axle centre, whose pose (x, y, φ) the motion moves."""

    wheelbase: float
    encoder_offset: float
    mount: tuple[float, float] = (0.0, 0.0)

    def twist(self, speed, steering) -> tuple[np.ndarray, np.ndarray]:
        """The rear axle centre's (v, ω)."""
        return kinematics.ackerman_twist(speed, steering, self.wheelbase, self.encoder_offset)

    def twist_jacobian(self, speed, steering) -> np.ndarray:
        """∂(v, ω)/∂(v_e, α) (..., 2, 2)."""
        speed, steering = np.broadcast_arrays(np.asarray(speed, dtype=float), np.asarray(steering, dtype=float))
        L, h = self.wheelbase, self.encoder_offset
        T, sec2 = np.tan(steering), 1.0 / np.cos(steering) ** 2
        D = 1.0 - h * T / L
        v = speed / D
        dv_da = speed * h * sec2 / (L * D**2)
        J = np.empty(speed.shape + (2, 2))
        J[..., 0, 0] = 1.0 / D
        J[..., 0, 1] = dv_da
        J[..., 1, 0] = T / (L * D)
        J[..., 1, 1] = (T * dv_da + v * sec2) / L
        return J

    def rates(self, x, speed, steering) -> np.ndarray:
        """ẋ = f(x, u) (..., 3) of the sensor pose x (..., 3)."""
        x = np.asarray(x, dtype=float)
        v, w = self.twist(speed, steering)
        a, b = self.mount
        c, s = np.cos(x[..., 2]), np.sin(x[..., 2])
        return np.stack([v * c - w * (a * s + b * c), v * s + w * (a * c - b * s), w], axis=-1)

    def predict(self, x, speed, steering, dt) -> np.ndarray:
        """The Euler step x' = x + f(x, u) dt (heading wrapped)."""
        x = np.asarray(x, dtype=float)
        out = x + self.rates(x, speed, steering) * np.asarray(dt, dtype=float)[..., None]
        out[..., 2] = wrap_angle(out[..., 2])
        return out

    def jacobians(self, x, speed, steering, dt) -> tuple[np.ndarray, np.ndarray]:
        """G = ∂x'/∂x (..., 3, 3) and V = ∂x'/∂(v_e, α) (..., 3, 2) of :meth:`predict`."""
        x = np.asarray(x, dtype=float)
        v, w = self.twist(speed, steering)
        dt = np.asarray(dt, dtype=float)
        a, b = self.mount
        c, s = np.cos(x[..., 2]), np.sin(x[..., 2])
        v, w, dt, c, s = np.broadcast_arrays(v, w, dt, c, s)
        G = np.zeros(c.shape + (3, 3))
        G[..., 0, 0] = G[..., 1, 1] = G[..., 2, 2] = 1.0
        G[..., 0, 2] = dt * (-v * s - w * (a * c - b * s))
        G[..., 1, 2] = dt * (v * c - w * (a * s + b * c))
        F = np.zeros(c.shape + (3, 2))  # ∂f/∂(v, ω)
        F[..., 0, 0], F[..., 1, 0] = c, s
        F[..., 0, 1], F[..., 1, 1], F[..., 2, 1] = -(a * s + b * c), a * c - b * s, 1.0
        return G, dt[..., None, None] * F @ self.twist_jacobian(speed, steering)


def observe(x, landmarks) -> np.ndarray:
    """h(x, m) = [range, bearing] of landmarks (..., 2) from robot pose x (..., 3); bearing wrapped."""
    x = np.asarray(x, dtype=float)
    m = np.asarray(landmarks, dtype=float)
    dx = m[..., 0] - x[..., 0]
    dy = m[..., 1] - x[..., 1]
    return np.stack([np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - x[..., 2])], axis=-1)


def observation_jacobians(x, landmarks) -> tuple[np.ndarray, np.ndarray]:
    """H_x = ∂h/∂x (..., 2, 3) and H_m = ∂h/∂m (..., 2, 2)."""
    x = np.asarray(x, dtype=float)
    m = np.asarray(landmarks, dtype=float)
    dx = m[..., 0] - x[..., 0]
    dy = m[..., 1] - x[..., 1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    Hm = np.empty(dx.shape + (2, 2))
    Hm[..., 0, 0] = dx / r
    Hm[..., 0, 1] = dy / r
    Hm[..., 1, 0] = -dy / q
    Hm[..., 1, 1] = dx / q
    Hx = np.zeros(dx.shape + (2, 3))
    Hx[..., :, :2] = -Hm
    Hx[..., 1, 2] = -1.0
    return Hx, Hm


class RangeBearingNoise(StrEnum):
    """How the stated observation noise R (2, 2) applies to observation j."""

    POLAR = "polar"  # R_j = R
    CARTESIAN = "cartesian"  # R_j = diag(σ², σ²/r_j²), σ² = R[0, 0]: isotropic σ² I in the plane (Victoria Park states its trees so)


def observation_covariances(R: np.ndarray, ranges: np.ndarray, noise: RangeBearingNoise | str) -> np.ndarray:
    """R_j (M, 2, 2) of M observations at ranges (M,) [m] under the stated (range, bearing) covariance R (2, 2).

    Cartesian: a point observed at range r with isotropic noise σ² I has range variance σ² and bearing variance σ²/r²,
    uncorrelated (the polar Jacobian's rows are orthogonal); ranges are floored at 1e-9 m.
    """
    R = np.asarray(R, dtype=float)
    ranges = np.asarray(ranges, dtype=float)
    if RangeBearingNoise(noise) == RangeBearingNoise.POLAR:
        return np.broadcast_to(R, (ranges.size, 2, 2))
    Rz = np.zeros((ranges.size, 2, 2))
    Rz[:, 0, 0] = R[0, 0]
    Rz[:, 1, 1] = R[0, 0] / np.maximum(ranges, 1e-9) ** 2
    return Rz


def inverse_observe(x, z) -> np.ndarray:
    """Landmark position (..., 2) from robot pose x (..., 3) and observation z = (range, bearing) (..., 2)."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    ang = x[..., 2] + z[..., 1]
    return np.stack([x[..., 0] + z[..., 0] * np.cos(ang), x[..., 1] + z[..., 0] * np.sin(ang)], axis=-1)


def inverse_observation_jacobians(x, z) -> tuple[np.ndarray, np.ndarray]:
    """∂m/∂x (..., 2, 3) and ∂m/∂z (..., 2, 2) of :func:`inverse_observe`."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    ang = x[..., 2] + z[..., 1]
    c, s, r = np.cos(ang), np.sin(ang), z[..., 0]
    Gx = np.zeros(ang.shape + (2, 3))
    Gx[..., 0, 0] = Gx[..., 1, 1] = 1.0
    Gx[..., 0, 2] = -r * s
    Gx[..., 1, 2] = r * c
    Gz = np.empty(ang.shape + (2, 2))
    Gz[..., 0, 0] = c
    Gz[..., 0, 1] = -r * s
    Gz[..., 1, 0] = s
    Gz[..., 1, 1] = r * c
    return Gx, Gz


def compose_jacobians(x, delta) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of x' = x ⊕ δ (odometry-increment motion): ∂x'/∂x and ∂x'/∂δ, each (..., 3, 3)."""
    x = np.asarray(x, dtype=float)
    d = np.asarray(delta, dtype=float)
    c, s = np.cos(x[..., 2]), np.sin(x[..., 2])
    shape = c.shape
    Jx = np.zeros(shape + (3, 3))
    Jx[..., 0, 0] = Jx[..., 1, 1] = Jx[..., 2, 2] = 1.0
    Jx[..., 0, 2] = -s * d[..., 0] - c * d[..., 1]
    Jx[..., 1, 2] = c * d[..., 0] - s * d[..., 1]
    Jd = np.zeros(shape + (3, 3))
    Jd[..., 0, 0] = c
    Jd[..., 0, 1] = -s
    Jd[..., 1, 0] = s
    Jd[..., 1, 1] = c
    Jd[..., 2, 2] = 1.0
    return Jx, Jd


def propagate_covariance(P0: np.ndarray, G: np.ndarray, M: np.ndarray) -> np.ndarray:
    """All covariances of ``P_{k+1} = G_k P_k G_kᵀ + M_k`` for ``G_k = [[I₂, g_k], [0, 1]]``.

    P0 (3, 3), G (K, 3, 3) (only ``g_k = G_k[:2, 2]`` is used), M (K, 3, 3) → (K + 1, 3, 3).

    With ``S_n = Σ_{i<n} g_i`` the product ``G_{n−1}⋯G_k = [[I, S_n − S_k], [0, 1]]``, so
    ``P_n = Σ_j Φ_j X_j Φ_jᵀ`` over the terms ``X_j`` ∈ {P_0, M_0, …, M_{n−1}} each carried by
    ``Φ_j = [[I, a_j], [0, 1]]``, ``a_j = S_n − T_j`` (``T = S_0`` for P_0, ``T = S_{k+1}``
    for M_k). For ``X = [[A, c], [cᵀ, m]]``, ``Φ X Φᵀ = [[A + a cᵀ + c aᵀ + m a aᵀ, c + m a], ·]``.
    Summing, with prefix sums over the terms present at n::

        C1 = Σ (A − T cᵀ − c Tᵀ + m T Tᵀ),   C2 = Σ (c − m T),   C3 = Σ m
        P_n[:2, :2] = C1 + S_n C2ᵀ + C2 S_nᵀ + C3 S_n S_nᵀ,   P_n[:2, 2] = C2 + C3 S_n,   P_n[2, 2] = C3
    """
    g = G[:, :2, 2]
    S = np.vstack([np.zeros((1, 2)), np.cumsum(g, axis=0)])  # S_0 … S_K
    X = np.concatenate([P0[None], M], axis=0)  # term j = 0 is P0, j = k + 1 is M_k
    T = np.vstack([np.zeros((1, 2)), S[1:]])  # T_0 = S_0, T_{k+1} = S_{k+1}
    A, c, m = X[:, :2, :2], X[:, :2, 2], X[:, 2, 2]
    Tc = T[:, :, None] * c[:, None, :]
    C1 = np.cumsum(A - Tc - np.swapaxes(Tc, 1, 2) + m[:, None, None] * T[:, :, None] * T[:, None, :], axis=0)
    C2 = np.cumsum(c - m[:, None] * T, axis=0)
    C3 = np.cumsum(m)
    SC2 = S[:, :, None] * C2[:, None, :]
    P = np.empty((len(S), 3, 3))
    P[:, :2, :2] = C1 + SC2 + np.swapaxes(SC2, 1, 2) + C3[:, None, None] * S[:, :, None] * S[:, None, :]
    P[:, :2, 2] = C2 + C3[:, None] * S
    P[:, 2, :2] = P[:, :2, 2]
    P[:, 2, 2] = C3
    return P


def compose_chain(start, P0, deltas, C) -> tuple[np.ndarray, np.ndarray]:
    """Poses and covariances of ``start ⊕ δ_1 ⊕ … ⊕ δ_k`` for k = 1…K, with uncertain increments.

    start (3,), P0 (3, 3) its covariance; deltas (K, 3) body-frame increments with covariances C (K, 3, 3)::

        x_k = x_{k−1} ⊕ δ_k,   P_k = J_x P_{k−1} J_xᵀ + J_δ C_k J_δᵀ      (J_x, J_δ = compose_jacobians(x_{k−1}, δ_k))

    computed in closed form (:func:`propagate_covariance`: J_x = [[I₂, g_k], [0, 1]]). Returns (K, 3), (K, 3, 3).
    """
    deltas = np.asarray(deltas, dtype=float).reshape(-1, 3)
    poses = accumulate(start, deltas)
    Jx, Jd = compose_jacobians(poses[:-1], deltas)
    P = propagate_covariance(np.asarray(P0, dtype=float), Jx, Jd @ C @ np.swapaxes(Jd, 1, 2))
    return poses[1:], P[1:]
