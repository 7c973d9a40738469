"""The EKF localizer of the design notes, on filterpy's ``ExtendedKalmanFilter``.

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

filterpy's ``predict()`` is linear (x = F x + B u). This module keeps its covariance step and
overrides the extension point ``predict_x`` with the nonlinear model (``u`` is the increment δ),
with ``F`` set to the Jacobian and ``Q`` to the noise of this Δt before each call. Because δ does
not depend on x, F = ∂(x ⊕ δ)/∂x and V = ∂(x ⊕ δ)/∂δ · ∂δ/∂u come from
:func:`slamarena.estimators.models.compose_jacobians` (equal to the model's G, V — tested against finite
differences), and δ, ∂δ/∂u of every Twist row are computed once, vectorised, in :meth:`run`.

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
NIS = yᵀ S⁻¹ y (filterpy's ``y`` and ``SI`` of the update) is compared with the χ² quantile of
the measurement dimension at ``gate_confidence`` (per sensor; 1.0 disables the gate). A rejected
update is undone (x, P are the prior again) and counted per sensor and reason: ``nonfinite`` (NaN/inf value or stamp),
``gate``, ``too_old`` (older than the history), ``unknown_landmark`` / ``unknown_beacon`` (no such id in the map).
A gate alone can lock a filter out for good: once the prediction has drifted beyond its own
covariance (wheel slip, a wrong noise model) every fix is "an outlier". After ``max_rejections``
consecutive gated-out measurements of one sensor (default 5; 0 disables) the filter treats
itself, not the sensor, as wrong: it scales P by α = NIS/χ²-threshold (> 1: the inflation that
makes S as large as the innovation says it is) and applies the measurement (counted in
``recoveries_<sensor>``).
Non-finite motion input is rejected and counted (``motion``/``nonfinite``); Δt ≤ 0 raises ``ValueError``.

Time, multi-rate input and delayed measurements
-----------------------------------------------
:meth:`EKFLocalizer.process` takes inputs with their own stamps in any arrival order:
``("twist", (v, ω, dt))``, ``("increment", (dx, dy, dθ))``, ``("gps", (x, y))``, ``("imu", yaw)``,
``("landmark", (range, bearing, mx, my))`` (or an (M, 4) array), ``("beacon", (range, bx, by))`` (or (M, 3)). Between events the filter is
propagated with the commands in force (:func:`slamarena.estimators.stepping.twist_pieces`). After each
input a snapshot (t, kind, value, x, P) joins a history covering ``history_length`` seconds. An
input older than the filter's time restores the last snapshot at or before its stamp and replays
the later inputs in time order (robot_localization's lagged-data smoothing); one older than the
whole history is rejected (``too_old``). :meth:`EKFLocalizer.run` walks ``Sequence.events()``
through the same machinery and records one pose and covariance per event.

Defaults (the notes): EULER, Q = diag(0.01, 0.01, 0.01) per 0.02 s step, R_gps = diag(1e-4, 1e-4),
R_imu = 1e-3; and (not in the notes) R_landmark = diag(0.1², 0.05²), R_beacon = 1 m², gate confidence 0.999,
max_rejections 5, history 1 s, initial_cov = diag(1e-4, 1e-4, 1e-4), heading in ENU. ``use_sequence_noise=True`` replaces R_gps, R_imu,
R_landmark and twist_cov by the noise the sequence states (e.g. a simulator's true noise).

Diagnostics of :meth:`run`: ``nis_<sensor>``, ``nis_<sensor>_t``, ``nis_<sensor>_accepted`` and
``nis_dim_<sensor>`` for sensor in gps, imu, landmark, beacon (NIS of every measurement that reached the
gate, as finally processed: a replay replaces the records of the steps it redoes), and ``rejected_<sensor>_<reason>``
counts; ``meta["rejected"]`` holds the same counts as a nested dict. ``nis``, ``nis_dof`` and
``nis_t`` merge all sensors in time order (the names :mod:`slamarena.experiments.metrics` reads).
"""
from __future__ import annotations

import time
from bisect import bisect_right, insort
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from scipy.stats import chi2

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Increments, Sequence, Twist
from slamarena.estimators.models import MOTION_MODELS, compose_jacobians, observation_jacobians, observe
from slamarena.estimators.stepping import twist_pieces

__all__ = ["EKFLocalizer", "compass_to_yaw", "KINDS", "SENSORS"]

#: input kinds of :meth:`EKFLocalizer.process` → the sensor they are counted under
KINDS: dict[str, str] = {"twist": "motion", "increment": "motion", "gps": "gps", "imu": "imu", "landmark": "landmark", "beacon": "beacon"}
#: measurement sensors and their dimension
SENSORS: dict[str, int] = {"gps": 2, "imu": 1, "landmark": 2, "beacon": 1}
#: Sequence stream name → input kind (the motion stream maps by its type)
_STREAM_KIND = {"gps": "gps", "heading": "imu", "range_bearing": "landmark", "beacon_ranges": "beacon"}
Q_UNITS = ("per_step", "per_second")
HEADING_CONVENTIONS = ("enu", "compass")

_ORIGIN = np.zeros(3)
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


def _matrix(value, n: int, name: str) -> np.ndarray:
    """A covariance from a scalar, a diagonal (n,) or a full (n, n) list; symmetric PSD checked."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape == (n,):
        a = np.diag(a)
    if a.shape != (n, n):
        raise ValueError(f"{name} must be a scalar, {n} diagonal values or an {n}x{n} matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or not np.allclose(a, a.T) or np.linalg.eigvalsh(a).min() < -1e-12:
        raise ValueError(f"{name} must be a finite symmetric positive semi-definite matrix")
    return a


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


@dataclass
class _Snapshot:
    """The filter right after input (t, kind, value) was applied, with the diagnostic records
    (NIS values, rejections) of that step: they become final when the snapshot leaves the
    history, and are discarded with it when a delayed input forces a replay."""

    t: float
    kind: str
    value: object
    x: np.ndarray
    P: np.ndarray
    records: list
    streak: dict


class EKFLocalizer:
    """EKF localization with cmd_vel/odometry prediction, GPS, IMU yaw, known-landmark and known-beacon updates.

    All parameters are plain types so an experiment config can construct it; every one has the
    default of the design notes or a documented choice (see the module docstring).
    """

    def __init__(
        self,
        motion_model: str = "euler",
        Q=(0.01, 0.01, 0.01),
        q_unit: str = "per_step",
        nominal_dt: float = 0.02,
        twist_cov=None,
        increment_cov=(1e-4, 1e-4, 1e-4),
        R_gps=(1e-4, 1e-4),
        R_imu: float = 1e-3,
        R_landmark=(0.01, 0.0025),
        R_beacon: float = 1.0,
        beacon_bias: float = 0.0,
        gate_confidence: float | dict = 0.999,
        history_length: float = 1.0,
        max_rejections: int = 5,
        initial_cov=(1e-4, 1e-4, 1e-4),
        heading_convention: str = "enu",
        magnetic_declination: float = 0.0,
        use_sequence_noise: bool = False,
    ):
        if motion_model not in MOTION_MODELS:
            raise ValueError(f"motion_model must be one of {sorted(MOTION_MODELS)}, got {motion_model!r}")
        if q_unit not in Q_UNITS:
            raise ValueError(f"q_unit must be one of {Q_UNITS}, got {q_unit!r}")
        if heading_convention not in HEADING_CONVENTIONS:
            raise ValueError(f"heading_convention must be one of {HEADING_CONVENTIONS}, got {heading_convention!r}")
        if not (np.isfinite(nominal_dt) and nominal_dt > 0):
            raise ValueError("nominal_dt must be > 0")
        if not (np.isfinite(history_length) and history_length >= 0):
            raise ValueError("history_length must be >= 0 seconds")
        self.model = MOTION_MODELS[motion_model]
        self.Q = _matrix(Q, 3, "Q")
        self.q_unit = q_unit
        self.nominal_dt = float(nominal_dt)
        self.twist_cov = None if twist_cov is None else _matrix(twist_cov, 2, "twist_cov")
        self.increment_cov = _matrix(increment_cov, 3, "increment_cov")
        self.R_gps = _matrix(R_gps, 2, "R_gps")
        self.R_imu = _matrix(R_imu, 1, "R_imu")
        self.R_landmark = _matrix(R_landmark, 2, "R_landmark")
        self.R_beacon = _matrix(R_beacon, 1, "R_beacon")
        if not np.isfinite(beacon_bias):
            raise ValueError(f"beacon_bias must be a finite number of metres, got {beacon_bias!r}")
        self.beacon_bias = float(beacon_bias)
        self.gate = self._gates(gate_confidence)
        self.gate_confidence = gate_confidence
        self.history_length = float(history_length)
        if int(max_rejections) != max_rejections or max_rejections < 0:
            raise ValueError(f"max_rejections must be an integer >= 0, got {max_rejections!r}")
        self.max_rejections = int(max_rejections)
        self.initial_cov = _matrix(initial_cov, 3, "initial_cov")
        self.heading_convention = heading_convention
        self.magnetic_declination = float(magnetic_declination)
        self.use_sequence_noise = bool(use_sequence_noise)
        self._configured_noise = (self.R_gps, self.R_imu, self.R_landmark, self.twist_cov, self.increment_cov)
        self.reset()

    @staticmethod
    def _gates(confidence) -> dict[str, float]:
        per_sensor = confidence if isinstance(confidence, dict) else {s: confidence for s in SENSORS}
        unknown = set(per_sensor) - set(SENSORS)
        if unknown:
            raise ValueError(f"gate_confidence: unknown sensors {sorted(unknown)}; known: {sorted(SENSORS)}")
        gates = {}
        for sensor, dim in SENSORS.items():
            c = float(per_sensor.get(sensor, 0.999))
            if not 0.0 < c <= 1.0:
                raise ValueError(f"gate_confidence[{sensor}] must be in (0, 1], got {c}")
            gates[sensor] = np.inf if c == 1.0 else float(chi2.ppf(c, dim))
        return gates

    # ------------------------------------------------------------------ state
    def reset(self, pose=(0.0, 0.0, 0.0), cov=None, t: float | None = None) -> None:
        """Start again at ``pose`` with covariance ``cov`` (default ``initial_cov``) at time ``t``."""
        self._kf = _Filter(dim_x=3, dim_z=2)
        pose = np.asarray(pose, dtype=float).reshape(3).copy()
        pose[2] = wrap_angle(pose[2])
        self._kf.x = pose
        self._kf.P = self.initial_cov.copy() if cov is None else _matrix(cov, 3, "cov")
        self._t = None if t is None else float(t)
        self._commands: list[tuple[float, float, float, float]] = []
        self._twist: Twist | None = None
        self._source: Twist | None = None
        self._row_cache: tuple[np.ndarray, np.ndarray] | None = None  # δ and ∂δ/∂u of every row of _source
        self._history: list[_Snapshot] = []
        self._history_t: list[float] = []
        self._records: list | None = None  # records of the step in progress (None: outside a timed step)
        self._final_rejected: dict[str, dict[str, int]] = {s: {} for s in ("motion", *SENSORS)}
        self._final_nis: dict[str, list[tuple[float, float, bool]]] = {s: [] for s in SENSORS}
        self._final_recovered: dict[str, int] = {s: 0 for s in SENSORS}
        self._streak: dict[str, int] = {s: 0 for s in SENSORS}  # consecutive gate rejections per sensor
        if t is not None:
            self._push(self._t, "start", None)

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
        Q = self.Q * (dt / self.nominal_dt if self.q_unit == "per_step" else dt)
        if self.twist_cov is not None:
            Q = Q + V @ self.twist_cov @ V.T * ((dt if period is None else period) / dt)
        return Q

    def predict(self, v: float, omega: float, dt: float, period: float | None = None) -> bool:
        """Propagate with (v, ω) held for ``dt`` > 0 seconds. Non-finite (v, ω) are rejected (False).

        ``period``: the duration of the command this is a piece of (default ``dt``), for ``twist_cov``.
        """
        dt = float(dt)
        if not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"predict: dt must be a finite number > 0, got {dt!r}")
        if not (np.isfinite(v) and np.isfinite(omega)):
            self._reject("motion", "nonfinite")
            return False
        delta = self.model.increment(v, omega, dt)
        D = self.model.jacobians(_ORIGIN, v, omega, dt)[1]
        self._predict_delta(delta, D, dt, period)
        return True

    def _predict_delta(self, delta: np.ndarray, D: np.ndarray, dt: float, period: float | None) -> None:
        """x⁻ = x ⊕ δ with F = ∂(x ⊕ δ)/∂x and V = ∂(x ⊕ δ)/∂δ · ∂δ/∂u (D = ∂δ/∂u, the model's V at the origin).

        This is the model's (G, V) at x: δ does not depend on x, so only the composition does.
        """
        F, J_delta = compose_jacobians(self._kf.x, delta)
        self._kf.F = F
        self._kf.Q = self.process_noise(dt, J_delta @ D, period)
        self._kf.predict(u=delta)

    def predict_increment(self, delta, cov=None) -> bool:
        """Propagate with a body-frame odometry increment δ (3,) of covariance ``cov`` (default ``increment_cov``)."""
        delta = np.asarray(delta, dtype=float).reshape(3)
        C = self.increment_cov if cov is None else np.asarray(cov, dtype=float).reshape(3, 3)
        if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(C))):
            self._reject("motion", "nonfinite")
            return False
        Jx, Jd = compose_jacobians(self._kf.x, delta)
        self._kf.F = Jx
        self._kf.Q = Jd @ C @ Jd.T
        self._kf.predict(u=delta)
        return True

    # ------------------------------------------------------------------ updates
    def update_gps(self, xy) -> bool:
        """GPS fix (x, y) [m]. Returns whether it was applied (False: non-finite or gated out)."""
        return self._update("gps", np.asarray(xy, dtype=float).reshape(2), _h_gps, _H_gps, self.R_gps, _residual_difference)

    def update_imu(self, yaw) -> bool:
        """Absolute yaw θ [rad], counter-clockwise from east (see :func:`compass_to_yaw` for a compass)."""
        return self._update("imu", np.asarray(yaw, dtype=float).reshape(1), _h_imu, _H_imu, self.R_imu, _residual_imu)

    def update_landmark(self, range, bearing, landmark_xy) -> bool:
        """Range [m] and bearing [rad, relative to the heading] of the known landmark at ``landmark_xy``."""
        m = np.asarray(landmark_xy, dtype=float).reshape(2)
        if not np.all(np.isfinite(m)):
            raise ValueError(f"update_landmark: landmark position must be finite, got {m}")
        z = np.array([range, bearing], dtype=float)
        return self._update("landmark", z, _h_landmark, _H_landmark, self.R_landmark, _residual_range_bearing, (m,))

    def update_beacon(self, range, beacon_xy) -> bool:
        """Range [m] to the known beacon at ``beacon_xy`` (range-only; ``beacon_bias`` is added to h)."""
        b = np.asarray(beacon_xy, dtype=float).reshape(2)
        if not np.all(np.isfinite(b)):
            raise ValueError(f"update_beacon: beacon position must be finite, got {b}")
        z = np.array([range], dtype=float)
        return self._update("beacon", z, _h_beacon, _H_beacon, self.R_beacon, _residual_difference, (b, self.beacon_bias))

    def _update(self, sensor, z, hx, HJ, R, residual, args=()) -> bool:
        if not np.all(np.isfinite(z)):
            self._reject(sensor, "nonfinite")
            return False
        kf = self._kf
        prior = kf.x, kf.P  # filterpy's update rebinds x and P to new arrays: the prior stays intact
        kf.update(z, HJ, hx, R=R, args=args, hx_args=args, residual=residual)
        nis = float(kf.y @ kf.SI @ kf.y)  # filterpy's innovation y and S⁻¹ of this update
        gate = self.gate[sensor]
        accepted = nis <= gate
        diverged = not accepted and 0 < self.max_rejections <= self._streak[sensor]
        self._note(("nis", sensor, np.nan if self._t is None else self._t, nis, accepted or diverged))
        if diverged:  # the sensor has been refused too often in a row: the filter, not the sensor, is off
            kf.x, kf.P = prior[0], prior[1] * (nis / gate)
            kf.update(z, HJ, hx, R=R, args=args, hx_args=args, residual=residual)
            self._note(("recover", sensor))
        elif not accepted:
            kf.x, kf.P = prior
            self._streak[sensor] += 1
            self._reject(sensor, "gate")
            return False
        self._streak[sensor] = 0
        kf.x[2] = wrap_angle(kf.x[2])
        return True

    def _reject(self, sensor: str, reason: str) -> None:
        self._note(("reject", sensor, reason))

    def _note(self, record: tuple) -> None:
        if self._records is None:
            self._finalise(record)
        else:
            self._records.append(record)

    def _finalise(self, record: tuple) -> None:
        if record[0] == "reject":
            counts = self._final_rejected[record[1]]
            counts[record[2]] = counts.get(record[2], 0) + 1
        elif record[0] == "recover":
            self._final_recovered[record[1]] += 1
        else:
            self._final_nis[record[1]].append(record[2:])

    def _all_records(self):
        yield from (r for s in self._history for r in s.records)

    @property
    def recoveries(self) -> dict[str, int]:
        """Divergence recoveries per sensor (see "Gating" in the module docstring)."""
        out = dict(self._final_recovered)
        for r in self._all_records():
            if r[0] == "recover":
                out[r[1]] += 1
        return out

    @property
    def rejected(self) -> dict[str, dict[str, int]]:
        """Rejected measurements: sensor → reason → count (including the steps still in the history)."""
        out = {sensor: dict(counts) for sensor, counts in self._final_rejected.items()}
        for r in self._all_records():
            if r[0] == "reject":
                out[r[1]][r[2]] = out[r[1]].get(r[2], 0) + 1
        return out

    # ------------------------------------------------------------------ timed input
    def process(self, t: float, kind: str, value) -> None:
        """Feed one input with its own stamp, in any arrival order (module docstring: kinds, values).

        The first timed input starts the filter's clock (after :meth:`reset` without ``t``).
        """
        if kind not in KINDS:
            raise ValueError(f"unknown input kind {kind!r}; known: {sorted(KINDS)}")
        t = float(t)
        if not np.isfinite(t):
            self._reject(KINDS[kind], "nonfinite")
            return
        if self._t is None:
            self._t = t
            self._push(t, "start", None)
        if t < self._history_t[0]:
            self._reject(KINDS[kind], "too_old")
            return
        if kind == "twist":
            self._log_command(t, value)
        if t >= self._t:
            self._step(t, kind, value)
        else:
            self._rewind_and_replay(t, kind, value)

    def _log_command(self, t: float, value) -> None:
        v, omega, dt = (float(a) for a in np.asarray(value, dtype=float).reshape(3))
        if not np.isfinite(dt) or dt <= 0:
            raise ValueError(f"twist at t={t}: dt must be a finite number > 0, got {dt!r}")
        insort(self._commands, (t, v, omega, dt))
        self._twist = None

    def _motion_source(self) -> Twist | None:
        if self._source is not None:
            return self._source
        if self._twist is None and self._commands:
            t, v, omega, dt = (np.array(c) for c in zip(*self._commands))
            self._twist = Twist(t=t, v=v, omega=omega, dt=dt)
        return self._twist

    def _advance(self, t: float) -> None:
        source = self._motion_source()
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
        """Propagate to ``t``, apply the input, remember the result."""
        self._records = []
        self._advance(t)
        if kind == "gps":
            self.update_gps(value)
        elif kind == "imu":
            yaw = value
            if self.heading_convention == "compass":
                yaw = compass_to_yaw(value, self.magnetic_declination)
            self.update_imu(yaw)
        elif kind == "landmark":
            for r, b, mx, my in np.asarray(value, dtype=float).reshape(-1, 4):
                self.update_landmark(r, b, (mx, my))
        elif kind == "beacon":
            for r, bx, by in np.asarray(value, dtype=float).reshape(-1, 3):
                self.update_beacon(r, (bx, by))
        elif kind == "increment":
            delta, cov = value if isinstance(value, tuple) else (value, None)
            self.predict_increment(delta, cov)
        self._push(t, kind, value)

    def _push(self, t: float, kind: str, value) -> None:
        records, self._records = self._records or [], None
        self._history.append(_Snapshot(t, kind, value, self.x, self.P, records, dict(self._streak)))
        self._history_t.append(t)
        cutoff = t - self.history_length
        keep_from = bisect_right(self._history_t, cutoff) - 1  # newest snapshot at or before the cutoff: the anchor
        if keep_from > 0:
            for s in self._history[:keep_from]:
                for r in s.records:
                    self._finalise(r)
            del self._history[:keep_from]
            del self._history_t[:keep_from]
            anchor = self._history_t[0]
            if self._commands and self._commands[0][0] + self._commands[0][3] < anchor:
                self._commands = [c for c in self._commands if c[0] + c[3] >= anchor]
                self._twist = None

    def _rewind_and_replay(self, t: float, kind: str, value) -> None:
        k = bisect_right(self._history_t, t) - 1
        later = self._history[k + 1 :]
        anchor = self._history[k]
        del self._history[k + 1 :]
        del self._history_t[k + 1 :]
        self._kf.x = anchor.x.copy()
        self._kf.P = anchor.P.copy()
        self._streak = dict(anchor.streak)
        self._t = anchor.t
        self._step(t, kind, value)
        for s in later:
            self._step(s.t, s.kind, s.value)

    def history(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The snapshots still held: times (H,), states (H, 3), covariances (H, 3, 3)."""
        return (
            np.array(self._history_t),
            np.array([s.x for s in self._history]).reshape(-1, 3),
            np.array([s.P for s in self._history]).reshape(-1, 3, 3),
        )

    # ------------------------------------------------------------------ whole sequences
    def _configure_noise(self, sequence: Sequence) -> None:
        self.R_gps, self.R_imu, self.R_landmark, self.twist_cov, self.increment_cov = self._configured_noise
        if not self.use_sequence_noise:
            return
        noise = sequence.noise
        if noise.gps_cov is not None:
            self.R_gps = _matrix(noise.gps_cov, 2, "Noise.gps_cov")
        if noise.yaw_var is not None:
            self.R_imu = _matrix(noise.yaw_var, 1, "Noise.yaw_var")
        if noise.range_bearing_cov is not None:
            self.R_landmark = _matrix(noise.range_bearing_cov, 2, "Noise.range_bearing_cov")
        if noise.twist_cov is not None:
            self.twist_cov = _matrix(noise.twist_cov, 2, "Noise.twist_cov")
        if noise.increment_cov is not None:
            self.increment_cov = _matrix(noise.increment_cov, 3, "Noise.increment_cov")

    def _event_value(self, sequence: Sequence, stream: str, start: int, stop: int):
        if stream == "motion":
            motion = sequence.motion
            if isinstance(motion, Increments):
                return "increment", (motion.delta[start], None if motion.cov is None else motion.cov[start])
            return "twist", None
        if stream == "gps":
            return "gps", sequence.gps.xy[start]
        if stream == "heading":
            return "imu", sequence.heading.yaw[start]
        if stream == "beacon_ranges":
            br = sequence.beacon_ranges
            rows, xy = self._known(sequence, br.beacon_id[start:stop], "beacon")
            return "beacon", np.column_stack([br.range[start:stop][rows], xy])
        rb = sequence.range_bearing
        rows, xy = self._known(sequence, rb.landmark_id[start:stop], "landmark")
        return "landmark", np.column_stack([rb.range[start:stop][rows], rb.bearing[start:stop][rows], xy])

    def _known(self, sequence: Sequence, ids: np.ndarray, sensor: str) -> tuple[np.ndarray, np.ndarray]:
        """Rows of ``ids`` in ``sequence.landmarks`` and their positions; the others are counted."""
        lm = sequence.landmarks
        known = np.isin(ids, lm.ids) if lm is not None else np.zeros(ids.shape, dtype=bool)
        for _ in range(int((~known).sum())):
            self._reject(sensor, f"unknown_{sensor}")
        rows = np.flatnonzero(known)
        return rows, np.array([lm.position(i) for i in ids[rows]]).reshape(-1, 2)

    def run(self, sequence: Sequence) -> Estimate:
        """Localize along ``sequence``: one pose and covariance per event of ``sequence.events()``.

        Uses the motion stream (Twist or Increments), GPS, heading, and the range-bearing and
        beacon-range rows whose id is in ``sequence.landmarks``; scans are ignored. Starts at
        ``sequence.start_pose`` with ``initial_cov``.
        """
        self._configure_noise(sequence)
        self.reset(sequence.start_pose, t=sequence.t0)
        if isinstance(sequence.motion, Twist):
            m = sequence.motion
            self._source = m
            self._row_cache = (self.model.increment(m.v, m.omega, m.dt), self.model.jacobians(np.zeros((len(m), 3)), m.v, m.omega, m.dt)[1])
        t_table = sequence.event_table()[0]
        times = np.empty(t_table.size)
        poses = np.empty((t_table.size, 3))
        covs = np.empty((t_table.size, 3, 3))
        step_time = np.empty(t_table.size)
        k = 0
        for event in sequence.events():
            if event.stream == "scans":
                continue
            tic = time.perf_counter()
            kind, value = self._event_value(sequence, event.stream, event.start, event.stop)
            self._step(event.t, kind, value)
            step_time[k] = time.perf_counter() - tic
            times[k], poses[k], covs[k] = event.t, self._kf.x, self._kf.P
            k += 1
        return Estimate(
            method="ekf_localizer",
            t=times[:k],
            poses=poses[:k],
            pose_cov=covs[:k],
            step_time=step_time[:k],
            diagnostics=self.diagnostics(),
            meta={"sequence": sequence.name, "params": self.params(), "rejected": self.rejected, "recoveries": self.recoveries},
        )

    def diagnostics(self) -> dict[str, np.ndarray]:
        """NIS per sensor (values, times, accepted flags, dimension) and rejection counts."""
        out: dict[str, np.ndarray] = {}
        nis = {sensor: list(rows) for sensor, rows in self._final_nis.items()}
        for r in self._all_records():
            if r[0] == "nis":
                nis[r[1]].append(r[2:])
        for sensor, dim in SENSORS.items():
            rows = np.array(sorted(nis[sensor], key=lambda row: row[0]), dtype=float).reshape(-1, 3)
            out[f"nis_{sensor}_t"] = rows[:, 0]
            out[f"nis_{sensor}"] = rows[:, 1]
            out[f"nis_{sensor}_accepted"] = rows[:, 2].astype(bool)
            out[f"nis_dim_{sensor}"] = np.array(dim)
        t_all = np.concatenate([out[f"nis_{s}_t"] for s in SENSORS])
        order = np.argsort(t_all, kind="stable")
        out["nis_t"] = t_all[order]
        out["nis"] = np.concatenate([out[f"nis_{s}"] for s in SENSORS])[order]
        out["nis_dof"] = np.concatenate([np.full(out[f"nis_{s}"].size, d) for s, d in SENSORS.items()])[order]
        for sensor, counts in self.rejected.items():
            for reason, n in counts.items():
                out[f"rejected_{sensor}_{reason}"] = np.array(n)
        for sensor, n in self.recoveries.items():
            out[f"recoveries_{sensor}"] = np.array(n)
        return out

    def params(self) -> dict:
        """The configuration, JSON-serialisable (noise as used, after ``use_sequence_noise``)."""
        return {
            "motion_model": self.model.name,
            "Q": self.Q.tolist(),
            "q_unit": self.q_unit,
            "nominal_dt": self.nominal_dt,
            "twist_cov": None if self.twist_cov is None else self.twist_cov.tolist(),
            "R_gps": self.R_gps.tolist(),
            "R_imu": self.R_imu.tolist(),
            "R_landmark": self.R_landmark.tolist(),
            "R_beacon": self.R_beacon.tolist(),
            "beacon_bias": self.beacon_bias,
            "gate_confidence": self.gate_confidence,
            "history_length": self.history_length,
            "max_rejections": self.max_rejections,
            "heading_convention": self.heading_convention,
            "use_sequence_noise": self.use_sequence_noise,
        }
