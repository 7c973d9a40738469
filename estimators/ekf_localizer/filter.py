"""The filter of the EKF localizer: the design notes' models on filterpy's ``ExtendedKalmanFilter``.

State and frames
----------------
x = [x, y, θ] (3,): position east and north [m], heading θ counter-clockwise from east (x) [rad],
wrapped to (−π, π] after every step. P (3, 3) its covariance.

Prediction (velocity input u = (v, ω) held for Δt, the TRUE time since the previous event)
-----------------------------------------------------------------------------------------
The motion model is "compose with a body-frame increment" (:mod:`slamarena.estimators.models`)::

    δ = δ(u, Δt)                        (3,)   EULER (the notes): δ = (vΔt, 0, ωΔt); ARC optional
    x⁻ = x ⊕ δ                          (3,)   EULER: x + vΔt cosθ, y + vΔt sinθ, θ + ωΔt
    F = ∂x⁻/∂x                          (3, 3) EULER: [[1, 0, −vΔt sinθ], [0, 1, vΔt cosθ], [0, 0, 1]]
    V = ∂x⁻/∂u                          (3, 2)
    P⁻ = F P Fᵀ + Q(Δt)                 (3, 3)

filterpy's ``predict()`` is linear (x = F x + B u). :class:`_Filter` keeps its covariance step and
overrides the extension point ``predict_x`` with the nonlinear model (``u`` is the increment δ),
with ``F`` set to the Jacobian and ``Q`` to the noise of this Δt before each call. Because δ does
not depend on x, F = ∂(x ⊕ δ)/∂x and V = ∂(x ⊕ δ)/∂δ · ∂δ/∂u come from
:func:`slamarena.estimators.models.compose_jacobians` (equal to the model's G, V — tested against finite
differences), and δ, ∂δ/∂u of every row of a followed Twist stream are computed once, vectorised
(:meth:`EKFLocalizer.follow`).

Process noise Q(Δt) — the unit the notes leave unstated
-------------------------------------------------------
* ``q_unit="per_step"`` (the notes' reading): ``Q`` is the covariance added per nominal step
  Δt₀ = ``nominal_dt`` (0.02 s at the notes' 50 Hz); for another Δt it is scaled as a random walk,
  Q(Δt) = Q · Δt/Δt₀, so the result does not depend on how many events split an interval.
* ``q_unit="per_second"``: ``Q`` is a continuous-time density [unit²/s], Q(Δt) = Q · Δt.
  (per_step Q ≡ per_second Q/Δt₀: the notes' diag(0.01, 0.01, 0.01) per step is 0.5 m²/s,
  i.e. 0.1 m of position noise every 20 ms.)
* ``twist_cov`` M (2, 2), optional, adds control-space noise: each (v, ω) command carries an
  error ~ N(0, M), constant over the command's period τ (its ``Twist.dt``) and independent
  between commands (what the simulators do: ``Noise.twist_cov`` is a per-row covariance).
  Over Δt it adds V M Vᵀ · τ/Δt: exactly V M Vᵀ for a whole command (Δt = τ), and for a piece of
  a command (an event splits it) the random-walk share, so the pieces add up to the whole.
Odometry increments (``Increments`` input) predict with x⁻ = x ⊕ δ, F = ∂x⁻/∂x, Q = J_δ C J_δᵀ
(:func:`slamarena.estimators.models.compose_jacobians`), C from the row, the sequence or ``increment_cov``.

Updates (filterpy ``update`` with a ``residual`` function; θ wrapped after each)
------------------------------------------------------------------------------
GPS    z = (x, y)      h = H_gps x,  H_gps = [[1, 0, 0], [0, 1, 0]]  (2, 3),  R_gps (2, 2)
IMU    z = θ           h = H_imu x,  H_imu = [[0, 0, 1]]              (1, 3),  R_imu (1, 1); residual wrapped
Range-bearing to a KNOWN landmark m = (mx, my):
       z = (r, b)      h = observe(x, m),  H = ∂h/∂x (2, 3) (:func:`slamarena.estimators.models.observation_jacobians`),
                       R_landmark (2, 2); bearing residual wrapped
Range to a KNOWN beacon b = (bx, by) (range-only radio beacons, e.g. CMU Plaza):
       z = r           h = ‖b − p‖ + β,  H = [−(bx − x)/d, −(by − y)/d, 0] (1, 3) with d = ‖b − p‖,
                       R_beacon (1, 1); β = ``beacon_bias`` a constant range offset [m] (default 0)
    y = z ⊖ h(x⁻),  S = H P⁻ Hᵀ + R,  K = P⁻ Hᵀ S⁻¹,  x = x⁻ + K y,  P = (I − KH) P⁻ (I − KH)ᵀ + K R Kᵀ (Joseph, filterpy)

Gating and bad input
--------------------
NIS = yᵀ S⁻¹ y (filterpy's ``y`` and ``SI`` of the update; filterpy ≥ 2.0 — 1.4.5 never set ``SI``)
is compared with the χ² quantile of the measurement dimension at ``gate_confidence`` (per sensor;
1.0 disables the gate). A rejected update is undone (x, P are the prior again) and counted per
sensor and reason (:mod:`.diagnostics`). A gate alone can lock a filter out for good: once the
prediction has drifted beyond its own covariance (wheel slip, a wrong noise model) every fix is "an
outlier". After ``max_rejections`` consecutive gated-out measurements of one sensor (default 5; 0
disables) the filter treats itself, not the sensor, as wrong: it scales P by α = NIS/χ²-threshold
(> 1: the inflation that makes S as large as the innovation says it is) and applies the measurement
(a recovery). Landmarks and beacons are many references, not one sensor: their refusals in a row must
also come from at least two different ones (positions) that are not suspect, and the row taken must not
be suspect, before the filter blames itself. A reference is suspect once it was refused and another one
of the sensor was then accepted (the filter agreed with the map elsewhere), until it is accepted itself.
One landmark refused alone, however often, is evidence against that landmark (a surveyed position that
is wrong, a misread id: MRCLAM Dataset 1 has two landmarks' surveyed positions swapped), not against the
filter; forcing it in would move the filter by the map's error
(research/notebook/2026-11-28-mrclam-withheld.md). Suspects are still gated as usual: only the guard
ignores them.
Motion input that is not finite, or whose prediction is not (a control so large that
x⁻ or P⁻ overflows), is rejected and counted (``motion``/``nonfinite``) with the prior kept; an
increment covariance that is not symmetric positive semi-definite is rejected (``motion``/
``bad_covariance``); Δt ≤ 0 raises ``ValueError``.

Timed input
-----------
:meth:`EKFLocalizer.process` takes inputs with their own stamps in any arrival order:
``("twist", (v, ω, dt))``, ``("increment", δ)`` or ``("increment", (δ, C))`` (δ = (dx, dy, dθ)),
``("gps", (x, y))``, ``("imu", yaw)``, ``("landmark", (range, bearing, mx, my))`` (or an (M, 4)
array), ``("beacon", (range, bx, by))`` (or (M, 3)). An input is checked before anything changes: a
call that raises leaves the filter as it was. Between events the filter is propagated with the
commands in force (:func:`slamarena.estimators.stepping.twist_pieces`); input older than the
filter's time is rewound and replayed through the lagged-data history (:mod:`.history`).

Defaults (the notes): EULER, Q = diag(0.01, 0.01, 0.01) per 0.02 s step, R_gps = diag(1e-4, 1e-4),
R_imu = 1e-3; and (not in the notes) R_landmark = diag(0.1², 0.05²), R_beacon = 1 m², gate confidence 0.999,
max_rejections 5, history 1 s, initial_cov = diag(1e-4, 1e-4, 1e-4), heading in ENU. ``use_sequence_noise=True`` replaces R_gps, R_imu,
R_landmark, twist_cov and increment_cov by the noise the sequence states (e.g. a simulator's true noise).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from pydantic import NonNegativeInt, TypeAdapter

from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Sequence, Twist
from slamarena.estimators.models import MOTION_MODELS, chi2_gate, compose_jacobians, observation_jacobians, observe
from slamarena.estimators.stepping import twist_pieces
from slamarena.params import Covariance2, Covariance3, Field, Params, Probability, covariance

from .diagnostics import MOTION, SENSORS, Diagnostics, Sensor
from .history import History, Snapshot

__all__ = ["EKFLocalizer", "EKFLocalizerParams", "compass_to_yaw", "KINDS", "SEQUENCE_NOISE"]

#: input kinds of :meth:`EKFLocalizer.process` → the sensor they are counted under
KINDS: dict[str, str] = {
    "twist": MOTION,
    "increment": MOTION,
    "gps": "gps",
    "imu": "imu",
    "landmark": "landmark",
    "beacon": "beacon",
}
#: the parameters ``use_sequence_noise`` replaces → the ``Noise`` field of the sequence that replaces each
SEQUENCE_NOISE: dict[str, str] = {
    "R_gps": "gps_cov",
    "R_imu": "yaw_var",
    "R_landmark": "range_bearing_cov",
    "twist_cov": "twist_cov",
    "increment_cov": "increment_cov",
}
#: the gate confidence of a sensor a per-sensor ``gate_confidence`` leaves out
DEFAULT_GATE_CONFIDENCE = 0.999

_ORIGIN = np.zeros(3)
_COVARIANCE3 = TypeAdapter(Covariance3)
H_GPS = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
H_IMU = np.array([[0.0, 0.0, 1.0]])


def compass_to_yaw(psi, declination: float = 0.0):
    """ENU yaw θ (counter-clockwise from east) of a magnetic compass heading ψ (clockwise from
    magnetic north): θ = π/2 − (ψ + D), D the magnetic declination (east positive)."""
    return wrap_angle(0.5 * np.pi - (np.asarray(psi, dtype=float) + declination))


class _Filter(ExtendedKalmanFilter):
    """filterpy's EKF whose state prediction is the nonlinear composition x ⊕ u (u = body increment δ)."""

    def predict_x(self, u=0):
        self.x = compose(self.x, u)


# ---------------------------------------------------------------- measurement models: h(x), H = ∂h/∂x, z ⊖ h
def _residual_difference(z, h):
    return z - h


def _residual_imu(z, h):
    return wrap_angle(np.asarray(z - h, dtype=float).reshape(1))


def _residual_range_bearing(z, h):
    y = z - h
    return np.array([y[0], wrap_angle(y[1])])


def _h_gps(x):
    return H_GPS @ x


def _H_gps(x):
    return H_GPS


def _h_imu(x):
    return H_IMU @ x


def _H_imu(x):
    return H_IMU


def _h_landmark(x, m):
    return observe(x, m)


def _H_landmark(x, m):
    return observation_jacobians(x, m)[0]


def _h_beacon(x, b, bias):
    return np.array([np.hypot(b[0] - x[0], b[1] - x[1]) + bias])


def _H_beacon(x, b, bias):
    d = np.hypot(b[0] - x[0], b[1] - x[1])
    if d == 0.0:  # on top of the beacon: the range says nothing about the direction
        return np.zeros((1, 3))
    return np.array([[-(b[0] - x[0]) / d, -(b[1] - x[1]) / d, 0.0]])


# ---------------------------------------------------------------- input checks (before anything changes)
def _positive_dt(dt, what: str) -> float:
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"{what}: dt must be a finite number > 0, got {dt!r}")
    return dt


def _is_covariance(C: np.ndarray) -> bool:
    """Symmetric and positive semi-definite (to rounding)."""
    return bool(
        np.allclose(C, C.T, rtol=1e-9, atol=1e-12)
        and np.linalg.eigvalsh(0.5 * (C + C.T)).min() >= -1e-12 * max(1.0, np.abs(C).max())
    )


def _finite_positions(xy, what: str) -> np.ndarray:
    """Known landmark or beacon positions (M, 2); a non-finite one is an error of the caller, not of a sensor."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if not np.all(np.isfinite(xy)):
        raise ValueError(f"{what}: positions must be finite, got {xy.tolist()}")
    return xy


def _checked(t: float, kind: str, value):
    """The value of a timed input in the form :meth:`EKFLocalizer._apply` takes; ValueError if it cannot be applied."""
    if kind == "twist":
        v, omega, dt = np.asarray(value, dtype=float).reshape(3)
        return float(v), float(omega), _positive_dt(dt, f"twist at t={t}")
    if kind == "increment":
        delta, cov = value if isinstance(value, tuple) and len(value) == 2 else (value, None)
        return np.asarray(delta, dtype=float).reshape(3), None if cov is None else np.asarray(cov, dtype=float).reshape(
            3, 3
        )
    if kind == "gps":
        return np.asarray(value, dtype=float).reshape(2)
    if kind == "imu":
        return float(np.asarray(value, dtype=float).reshape(()))
    columns = 4 if kind == "landmark" else 3  # (range, bearing, mx, my) or (range, bx, by)
    rows = np.asarray(value, dtype=float).reshape(-1, columns)
    _finite_positions(rows[:, -2:], f"{kind} input at t={t}")
    return rows


class EKFLocalizerParams(Params):
    """Parameters of :class:`EKFLocalizer` (the design notes' defaults, or a stated choice: module docstring)."""

    motion_model: Literal["euler", "arc"] = Field(
        "euler",
        description="motion model of Twist input (estimators.models): the notes' Euler step or the exact constant-twist arc",
    )
    Q: Covariance3 = Field(
        (0.01, 0.01, 0.01),
        description="state process noise of (x [m²], y [m²], θ [rad²]) per nominal step or per second (q_unit)",
    )
    q_unit: Literal["per_step", "per_second"] = Field(
        "per_step",
        description="Q is added per nominal_dt (scaled as a random walk) or is a density per second [unit²/s]",
    )
    nominal_dt: float = Field(
        0.02, gt=0.0, allow_inf_nan=False, description="the step Δt₀ that a per_step Q is given for [s]"
    )
    twist_cov: Covariance2 | None = Field(
        None,
        description="noise of one (v [(m/s)²], ω [(rad/s)²]) command, held over its period; None: no control noise",
    )
    increment_cov: Covariance3 = Field(
        (1e-4, 1e-4, 1e-4),
        description="covariance of an odometry increment (dx [m²], dy [m²], dθ [rad²]) where neither its row nor the sequence states one",
    )
    R_gps: Covariance2 = Field((1e-4, 1e-4), description="GPS noise of (x [m²], y [m²])")
    R_imu: covariance(1) = Field(1e-3, description="IMU yaw noise [rad²]")
    R_landmark: Covariance2 = Field((0.01, 0.0025), description="landmark noise of (range [m²], bearing [rad²])")
    R_beacon: covariance(1) = Field(1.0, description="beacon range noise [m²]")
    beacon_bias: float = Field(
        0.0, allow_inf_nan=False, description="constant offset β added to every predicted beacon range [m]"
    )
    gate_confidence: Probability | dict[Sensor, Probability] = Field(
        DEFAULT_GATE_CONFIDENCE,
        description="χ² gate confidence, for every sensor or per sensor (gps, imu, landmark, beacon; "
        f"one left out: {DEFAULT_GATE_CONFIDENCE}); 1 disables a gate",
    )
    history_length: float = Field(
        1.0, ge=0.0, allow_inf_nan=False, description="time span of the snapshots kept to replay delayed input [s]"
    )
    max_rejections: NonNegativeInt = Field(
        5,
        description="consecutive gated-out measurements of one sensor (of landmarks and beacons: of two or more "
        "different, unsuspected ones) after which the filter inflates P and applies the next; 0: never",
    )
    initial_cov: Covariance3 = Field(
        (1e-4, 1e-4, 1e-4), description="covariance of the start pose (x [m²], y [m²], θ [rad²])"
    )
    heading_convention: Literal["enu", "compass"] = Field(
        "enu",
        description="IMU heading: ENU yaw (counter-clockwise from east) or compass heading (clockwise from magnetic north)",
    )
    magnetic_declination: float = Field(
        0.0, allow_inf_nan=False, description="declination D of a compass heading, east positive [rad]"
    )
    use_sequence_noise: bool = Field(
        False, description="replace R_gps, R_imu, R_landmark, twist_cov, increment_cov by the noise the sequence states"
    )


class EKFLocalizer:
    """EKF localization with cmd_vel/odometry prediction, GPS, IMU yaw, known-landmark and known-beacon updates
    (:class:`EKFLocalizerParams`; model and equations: module docstring)."""

    Params = EKFLocalizerParams

    def __init__(self, params: EKFLocalizerParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.model = MOTION_MODELS[self.params.motion_model]
        self.Q = np.asarray(self.params.Q)
        confidence = self.params.gate_confidence
        if not isinstance(confidence, dict):
            confidence = dict.fromkeys(SENSORS, confidence)
        self.gate = {
            sensor: chi2_gate(confidence.get(sensor, DEFAULT_GATE_CONFIDENCE), dim) for sensor, dim in SENSORS.items()
        }
        self._use_noise(self.params)
        self.reset()

    # ------------------------------------------------------------------ noise in force
    def use_noise_of(self, sequence: Sequence) -> None:
        """Use the parameters' noise, or with ``use_sequence_noise`` the noise ``sequence`` states where it
        states it (:data:`SEQUENCE_NOISE`); ``self.noise`` is then the parameters in force."""
        stated = {}
        if self.params.use_sequence_noise:
            for name, noise_field in SEQUENCE_NOISE.items():
                value = getattr(sequence.noise, noise_field)
                if value is not None:
                    stated[name] = np.asarray(value, dtype=float).tolist()
        self._use_noise(self.Params.of(self.params, stated))

    def _use_noise(self, noise: EKFLocalizerParams) -> None:
        self.noise = noise
        self.R = {sensor: np.asarray(getattr(noise, f"R_{sensor}")) for sensor in SENSORS}
        self.twist_cov = None if noise.twist_cov is None else np.asarray(noise.twist_cov)
        self.increment_cov = np.asarray(noise.increment_cov)

    # ------------------------------------------------------------------ state
    def reset(self, pose=(0.0, 0.0, 0.0), cov=None, t: float | None = None) -> None:
        """Start again at ``pose`` with covariance ``cov`` (default ``initial_cov``) at time ``t``."""
        pose = np.asarray(pose, dtype=float).reshape(3).copy()
        pose[2] = wrap_angle(pose[2])
        P = np.asarray(self.params.initial_cov if cov is None else _COVARIANCE3.validate_python(cov))
        self._kf = _Filter(dim_x=3, dim_z=2)
        self._kf.x, self._kf.P = pose, P
        self._t = None if t is None else float(t)
        self._source: Twist | None = None  # a followed Twist stream (else the commands of timed input)
        self._row_cache: tuple[np.ndarray, np.ndarray] | None = None  # δ and ∂δ/∂u of every row of _source
        self._history = History(self.params.history_length)
        self._final = Diagnostics()  # records of the steps that left the history and of calls outside a timed step
        self._log = self._final  # where records go: the timed step in progress, else the final record
        # per sensor: (its consecutive gate rejections, their sources, the suspect sources): "Gating" above
        self._streak = dict.fromkeys(SENSORS, (0, frozenset(), frozenset()))
        if t is not None:
            self._push(self._t, "start", None, Diagnostics())

    @property
    def x(self) -> np.ndarray:
        """State estimate (3,) — a copy."""
        return np.array(self._kf.x, dtype=float).reshape(3)

    @property
    def P(self) -> np.ndarray:
        """State covariance (3, 3) — a copy."""
        return np.array(self._kf.P, dtype=float)

    @property
    def t(self) -> float | None:
        """Time of the filter state (``None`` before the first timed input)."""
        return self._t

    # ------------------------------------------------------------------ prediction
    def process_noise(self, dt: float, V: np.ndarray, period: float | None = None) -> np.ndarray:
        """Q(Δt) (3, 3): the state-space random walk plus the control-space term V M Vᵀ · τ/Δt
        for a piece Δt of a command of period τ (default τ = Δt, a whole command)."""
        Q = self.Q * (dt / self.params.nominal_dt if self.params.q_unit == "per_step" else dt)
        if self.twist_cov is not None:
            Q = Q + V @ self.twist_cov @ V.T * ((dt if period is None else period) / dt)
        return Q

    def predict(self, v: float, omega: float, dt: float, period: float | None = None) -> bool:
        """Propagate with (v, ω) held for ``dt`` > 0 seconds. Non-finite (v, ω) are rejected (False).

        ``period``: the duration of the command this is a piece of (default ``dt``), for ``twist_cov``.
        """
        dt = _positive_dt(dt, "predict")
        if not (np.isfinite(v) and np.isfinite(omega)):
            self._log.reject(MOTION, "nonfinite")
            return False
        delta = self.model.increment(v, omega, dt)
        D = self.model.jacobians(_ORIGIN, v, omega, dt)[1]
        return self._predict_delta(delta, D, dt, period)

    def _predict_delta(self, delta: np.ndarray, D: np.ndarray, dt: float, period: float | None) -> None:
        """x⁻ = x ⊕ δ with F = ∂(x ⊕ δ)/∂x and V = ∂(x ⊕ δ)/∂δ · ∂δ/∂u (D = ∂δ/∂u, the model's V at the origin).

        This is the model's (G, V) at x: δ does not depend on x, so only the composition does.
        """
        F, J_delta = compose_jacobians(self._kf.x, delta)
        return self._propagate(delta, F, self.process_noise(dt, J_delta @ D, period))

    def _propagate(self, delta: np.ndarray, F: np.ndarray, Q: np.ndarray) -> bool:
        """filterpy's predict with x⁻ = x ⊕ δ, F and Q; a result that is not finite (a control so large that
        x⁻ or P⁻ overflows) is rejected and counted (``motion``/``nonfinite``) and the prior kept."""
        kf = self._kf
        prior = kf.x, kf.P, kf.F, kf.Q  # filterpy's predict rebinds x and P: the prior stays intact
        kf.F, kf.Q = F, Q
        kf.predict(u=delta)
        if np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P)):
            return True
        kf.x, kf.P, kf.F, kf.Q = prior
        self._log.reject(MOTION, "nonfinite")
        return False

    def predict_increment(self, delta, cov=None) -> bool:
        """Propagate with a body-frame odometry increment δ (3,) of covariance ``cov`` (default ``increment_cov``)."""
        delta = np.asarray(delta, dtype=float).reshape(3)
        C = self.increment_cov if cov is None else np.asarray(cov, dtype=float).reshape(3, 3)
        if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(C))):
            self._log.reject(MOTION, "nonfinite")
            return False
        if not _is_covariance(C):
            self._log.reject(MOTION, "bad_covariance")
            return False
        Jx, Jd = compose_jacobians(self._kf.x, delta)
        return self._propagate(delta, Jx, Jd @ C @ Jd.T)

    # ------------------------------------------------------------------ updates
    def update_gps(self, xy) -> bool:
        """GPS fix (x, y) [m]. Returns whether it was applied (False: non-finite or gated out)."""
        return self._update("gps", np.asarray(xy, dtype=float).reshape(2), _h_gps, _H_gps, _residual_difference)

    def update_imu(self, yaw) -> bool:
        """Absolute yaw θ [rad], counter-clockwise from east (see :func:`compass_to_yaw` for a compass)."""
        return self._update("imu", np.asarray(yaw, dtype=float).reshape(1), _h_imu, _H_imu, _residual_imu)

    def update_landmark(self, range, bearing, landmark_xy) -> bool:
        """Range [m] and bearing [rad, relative to the heading] of the known landmark at ``landmark_xy``."""
        m = _finite_positions(landmark_xy, "update_landmark")[0]
        z = np.array([range, bearing], dtype=float)
        return self._update("landmark", z, _h_landmark, _H_landmark, _residual_range_bearing, (m,), tuple(m))

    def update_beacon(self, range, beacon_xy) -> bool:
        """Range [m] to the known beacon at ``beacon_xy`` (range-only; ``beacon_bias`` is added to h)."""
        b = _finite_positions(beacon_xy, "update_beacon")[0]
        z = np.array([range], dtype=float)
        return self._update(
            "beacon", z, _h_beacon, _H_beacon, _residual_difference, (b, self.params.beacon_bias), tuple(b)
        )

    def _update(self, sensor, z, hx, HJ, residual, args=(), source=None) -> bool:
        """Apply z of ``sensor`` unless gated out; ``source`` names the reference measured (a landmark's or beacon's
        position; None for GPS and IMU), so that a lock-out is told from one bad reference (module docstring)."""
        if not np.all(np.isfinite(z)):
            self._log.reject(sensor, "nonfinite")
            return False
        kf, R = self._kf, self.R[sensor]
        prior = kf.x, kf.P  # filterpy's update rebinds x and P to new arrays: the prior stays intact
        kf.update(z, HJ, hx, R=R, args=args, hx_args=args, residual=residual)
        nis = float(kf.y @ kf.SI @ kf.y)  # filterpy's innovation y and S⁻¹ of this update
        gate = self.gate[sensor]
        accepted = nis <= gate
        streak, refused, suspects = self._streak[sensor]  # refusals in a row, their sources, the suspect sources
        diverged = (
            not accepted
            and 0 < self.params.max_rejections <= streak
            and (source is None or (source not in suspects and len((refused | {source}) - suspects) >= 2))
        )
        self._log.gated(sensor, np.nan if self._t is None else self._t, nis, accepted or diverged)
        if diverged:  # the sensor has been refused too often in a row: the filter, not the sensor, is off
            kf.x, kf.P = prior[0], prior[1] * (nis / gate)
            kf.update(z, HJ, hx, R=R, args=args, hx_args=args, residual=residual)
            self._log.recover(sensor)
        elif not accepted:
            kf.x, kf.P = prior
            self._streak[sensor] = (streak + 1, refused | {source} - {None}, suspects)
            self._log.reject(sensor, "gate")
            return False
        self._streak[sensor] = (0, frozenset(), (suspects | refused) - {source})
        kf.x[2] = wrap_angle(kf.x[2])
        return True

    # ------------------------------------------------------------------ diagnostics
    def record(self) -> Diagnostics:
        """Everything recorded so far: the final record and that of the steps still in the history."""
        return Diagnostics.total([self._final, *self._history.diagnostics()])

    @property
    def recoveries(self) -> dict[str, int]:
        """Divergence recoveries per sensor (see "Gating" in the module docstring)."""
        return self.record().recoveries

    @property
    def rejected(self) -> dict[str, dict[str, int]]:
        """Rejected input: sensor → reason → count (including the steps still in the history)."""
        return self.record().rejected

    def diagnostics(self) -> dict[str, np.ndarray]:
        """NIS per sensor (values, times, accepted flags, dimension) and rejection counts (:mod:`.diagnostics`)."""
        return self.record().arrays()

    # ------------------------------------------------------------------ timed input
    def process(self, t: float, kind: str, value) -> None:
        """Feed one input with its own stamp, in any arrival order (module docstring: kinds, values).

        The first timed input starts the filter's clock (after :meth:`reset` without ``t``).
        """
        if kind not in KINDS:
            raise ValueError(f"unknown input kind {kind!r}; known: {sorted(KINDS)}")
        t = float(t)
        value = _checked(t, kind, value)
        if not np.isfinite(t):
            self._log.reject(KINDS[kind], "nonfinite")
            return
        if self._t is None:
            self._t = t
            self._push(t, "start", None, Diagnostics())
        if t < self._history.start:
            self._log.reject(KINDS[kind], "too_old")
            return
        if kind == "twist":
            self._history.log_command(t, *value)
        if t >= self._t:
            self._step(t, kind, value)
            return
        anchor, inputs = self._history.rewind(t, kind, value)
        self._restore(anchor)
        for item in inputs:
            self._step(*item)

    def follow(self, twist: Twist) -> None:
        """Propagate with the rows of ``twist`` (a sequence's whole motion stream) instead of the commands of
        timed input; δ and ∂δ/∂u of every row are computed once, vectorised."""
        self._source = twist
        self._row_cache = (
            self.model.increment(twist.v, twist.omega, twist.dt),
            self.model.jacobians(np.zeros((len(twist), 3)), twist.v, twist.omega, twist.dt)[1],
        )

    def _advance(self, t: float) -> None:
        source = self._source if self._source is not None else self._history.twist()
        if source is not None and t > self._t:
            v, omega, dt, rows = twist_pieces(source, self._t, t, with_rows=True)
            for k in range(dt.size):
                r = rows[k]
                if self._row_cache is not None and dt[k] == source.dt[r] and np.isfinite(self._row_cache[0][r, 0]):
                    self._predict_delta(self._row_cache[0][r], self._row_cache[1][r], dt[k], None)  # a whole row
                else:
                    self.predict(v[k], omega[k], dt[k], source.dt[r])
        self._t = t

    def _step(self, t: float, kind: str, value) -> None:
        """Propagate to ``t`` (≥ the filter's time), apply the input (a checked value), remember the result."""
        step = self._log = Diagnostics()
        self._advance(t)
        self._apply(kind, value)
        self._log = self._final
        self._push(t, kind, value, step)

    def _apply(self, kind: str, value) -> None:
        if kind == "gps":
            self.update_gps(value)
        elif kind == "imu":
            self.update_imu(
                compass_to_yaw(value, self.params.magnetic_declination)
                if self.params.heading_convention == "compass"
                else value
            )
        elif kind == "landmark":
            for r, b, mx, my in value:
                self.update_landmark(r, b, (mx, my))
        elif kind == "beacon":
            for r, bx, by in value:
                self.update_beacon(r, (bx, by))
        elif kind == "increment":
            self.predict_increment(*value)

    def _push(self, t: float, kind: str, value, step: Diagnostics) -> None:
        for old in self._history.push(Snapshot(t, kind, value, self.x, self.P, dict(self._streak), step)):
            self._final += old.diagnostics

    def _restore(self, snapshot: Snapshot) -> None:
        self._kf.x, self._kf.P = snapshot.x.copy(), snapshot.P.copy()
        self._streak = dict(snapshot.streak)
        self._t = snapshot.t

    def history(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The snapshots still held: times (H,), states (H, 3), covariances (H, 3, 3)."""
        return self._history.arrays()

    # ``run(sequence) -> Estimate`` (one pose and covariance per event) is :func:`.run.run_sequence`, bound by the
    # package (this module does not import its runner)
