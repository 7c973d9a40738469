"""``sim:localization`` — the EKF localizer's world: cmd_vel at 50 Hz, GPS (x, y), IMU yaw.

Robot (differential drive, track width ``wheel_base`` b)
-------------------------------------------------------
* **Commands** ``u_c = (v_c, ω_c)`` at ``cmd_rate`` (rows ``t_k = t0 + k T``, ``T = 1/cmd_rate``):
  a smooth random profile — per channel a normalised sum of four sinusoids with random
  frequencies in [0.02, 0.15] Hz and phases, ``v_c = v_mean + v_amplitude·s_v(t)``,
  ``ω_c = omega_amplitude·s_ω(t)``, both faded in over the first ``ramp`` seconds (the
  robot starts at rest).
* **Actuators**: the commanded wheel surface speeds ``c_{L,R} = v_c ∓ ω_c b/2`` are executed
  through a first-order lag with time constant ``actuator_tau`` driven by white noise
  (an Ornstein–Uhlenbeck process around the lagged command whose stationary std is
  ``actuator_sigma`` [m/s]), integrated exactly on a fine grid of ``substeps`` per row
  (step ``h = T/substeps``): ``w_{n+1} = a w_n + (1 − a) c_n + actuator_sigma √(1 − a²) ξ_n``,
  ``a = exp(−h/τ)``; in substep n the wheel travels ``h (c_n + κ (w_n − c_n))``,
  ``κ = (1 − a) τ/h`` (the exact mean of the lag response). ``actuator_tau = 0``: no lag, the
  wheel runs at ``c_n + actuator_sigma ξ_n`` (white; ``actuator_sigma = 0`` executes the
  command exactly).
* **Ground contact**: the ground speed of each wheel is ``slip factor × executed speed``;
  the factor is 1 except in slip episodes ``slip = [(t_start, t_end, f)]`` (both wheels) or
  ``[(t_start, t_end, f_left, f_right)]``. The true body twist is ``v = (g_R + g_L)/2``,
  ``ω = (g_R − g_L)/b``; the truth is the arc motion model integrated on the fine grid.
* **Wheel odometry** measures the executed (not the ground) wheel travel of each row plus
  encoder noise ``N(0, encoder_sigma²)`` [m] per wheel per row, reported as the twist
  ``v_o = (d_R + d_L)/(2T)``, ``ω_o = (d_R − d_L)/(b T)``; it does not see slip.

``motion_source`` selects ``Sequence.motion``: ``"cmd_vel"`` (the commands, the notes' design)
or ``"odometry"``; everything else — the world, the truth, GPS, IMU — is identical for a
seed whichever input is chosen.

Noise.twist_cov — what the chosen input's error actually is
-----------------------------------------------------------
The input error ``e(t) = u_input(t) − u_true(t)`` (lag, actuator noise, encoder noise,
slip) is time-correlated, while the filters treat rows as white. This simulator measures,
on this run, the covariance **per second of command** of the integrated error:
``S = mean over whole 1-s windows of (∫_w e dt)(∫_w e dt)ᵀ / 1 s`` [(m/s)²·s, (rad/s)²·s]
(``meta["twist_psd"]``), and states ``Noise.twist_cov = S / T`` [(m/s)², (rad/s)²], the
per-row covariance (the unit every consumer uses: ``V Q Vᵀ`` per row) of a white input error
that accumulates the same error per second. For white per-row noise this equals the per-row
variance exactly (e.g. odometry without slip: ``diag(σ_e²/(2T²), 2σ_e²/(b²T²))``).

Sensors
-------
* GPS at ``gps_rate`` (stamps ``t0 + j/gps_rate``): true ``(x, y)`` + ``N(0, gps_sigma² I)``;
  fixes inside any ``gps_outages`` interval ``[t_start, t_end)`` are absent; each remaining fix
  is an outlier with probability ``gps_outlier_fraction``, displaced by
  ``gps_outlier_magnitude`` metres in a uniformly random direction
  (``meta["gps_outlier_index"]`` lists them). ``Noise.gps_cov = gps_sigma² I``.
* IMU at ``imu_rate``: yaw = true θ + ``imu_bias`` + ``N(0, imu_var)``, wrapped to (−π, π],
  counter-clockwise from +x (East) like the state. ``Noise.yaw_var = imu_var``.

Ground truth: the true pose at every command stamp and at the end of the last row
(``K + 1`` poses). Sensor values are sampled from the fine-grid truth by SE(2)
interpolation. Defaults follow the design notes: R_gps = diag(1e-4, 1e-4) (1 cm RTK),
R_imu = 1e-3 rad², Δt = 0.02 s.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import AfterValidator, ConfigDict, NonNegativeFloat, model_validator

from slamarena.params import Field, Params, with_params
from slamarena.resources import require_memory

from .. import kinematics
from ..geometry import interpolate_poses, wrap_angle
from ..sequence import Gps, Heading, Noise, Sequence, Trajectory, Twist

__all__ = ["simulate", "LocalizationWorldParams", "command_profile", "first_order_response"]


def command_profile(
    rng: np.random.Generator, t: np.ndarray, v_mean: float, v_amplitude: float, omega_amplitude: float, ramp: float
) -> tuple[np.ndarray, np.ndarray]:
    """Smooth random (v, ω) commands at times ``t`` measured from the start (see module docstring)."""
    out = []
    for _ in range(2):
        freq = rng.uniform(0.02, 0.15, 4)
        phase = rng.uniform(0.0, 2.0 * np.pi, 4)
        weight = rng.uniform(0.5, 1.0, 4)
        out.append(np.sin(2.0 * np.pi * freq * t[:, None] + phase) @ weight / weight.sum())
    fade = np.clip(t / ramp, 0.0, 1.0) if ramp > 0 else np.ones_like(t)
    fade = fade * fade * (3.0 - 2.0 * fade)
    return fade * (v_mean + v_amplitude * out[0]), fade * omega_amplitude * out[1]


def first_order_response(u: np.ndarray, a: float, w0: np.ndarray) -> np.ndarray:
    """``w_{n+1} = a w_n + u_n`` for inputs ``u`` (N, m) from ``w_0`` (m,): (N + 1, m), vectorised in blocks.

    Within a block of B steps ``w_{s+j} = a^j (w_s + Σ_{i<j} a^{−i−1} u_{s+i})``; B keeps
    ``a^{−B}`` far from overflow.
    """
    u = np.asarray(u, dtype=float)
    w = np.empty((u.shape[0] + 1,) + u.shape[1:])
    w[0] = w0
    if a == 0.0:
        w[1:] = u
        return w
    block = int(np.clip(20.0 / -math.log(a), 1, 4096)) if a < 1.0 else 4096
    powers = a ** np.arange(block + 1.0)
    for s in range(0, u.shape[0], block):
        chunk = u[s : s + block]
        B = chunk.shape[0]
        scaled = np.cumsum(chunk / powers[1 : B + 1, None], axis=0)
        w[s + 1 : s + B + 1] = powers[1 : B + 1, None] * (w[s] + scaled)
    return w


def _slip_factors(t_mid: np.ndarray, slip) -> np.ndarray:
    """Ground/wheel speed ratio (N, 2) of the left and right wheel at times ``t_mid``."""
    f = np.ones((t_mid.size, 2))
    for t_a, t_b, left, *right in slip:
        right = right[0] if right else left
        inside = (t_mid >= t_a) & (t_mid < t_b)
        f[inside] *= [left, right]
    return f


def _stamps(t0: float, t_end: float, rate: float) -> np.ndarray:
    """Sensor stamps ``t0 + j/rate`` within ``[t0, t_end]`` (a last stamp within rounding of ``t_end`` is kept, clipped)."""
    stamps = t0 + np.arange(int(math.floor((t_end - t0) * rate + 1e-9)) + 1) / rate
    return np.minimum(stamps, t_end)


def _interval(episode: tuple) -> tuple:
    if not episode[1] > episode[0]:
        raise ValueError(f"{episode!r}: t_end must be > t_start")
    return episode


#: ``(t_start, t_end)`` [s] with ``t_end > t_start``
Interval = Annotated[tuple[float, float], AfterValidator(_interval)]
#: ``(t_start, t_end, factor)`` (both wheels) or ``(t_start, t_end, left, right)``: ground/wheel speed ratios ≥ 0
SlipEpisode = Annotated[
    tuple[float, float, NonNegativeFloat] | tuple[float, float, NonNegativeFloat, NonNegativeFloat],
    AfterValidator(_interval),
]


class LocalizationWorldParams(Params):
    """Parameters of :func:`simulate` (seconds, metres, radians, rates in Hz; the model is in the module docstring)."""

    model_config = ConfigDict(allow_inf_nan=False)

    duration: float = Field(
        120.0, ge=1.0, description="length of the run [s] (≥ 1 s: the input noise is measured over 1-s windows)"
    )
    cmd_rate: float = Field(50.0, gt=0, description="command rate 1/T [Hz]")
    gps_rate: float = Field(5.0, gt=0, description="GPS rate [Hz]")
    imu_rate: float = Field(50.0, gt=0, description="IMU yaw rate [Hz]")
    gps_sigma: float = Field(0.01, ge=0, description="std of the GPS noise per axis [m]")
    imu_var: float = Field(0.001, ge=0, description="variance of the IMU yaw noise [rad²]")
    imu_bias: float = Field(0.0, description="constant IMU yaw bias [rad]")
    gps_outages: tuple[Interval, ...] = Field(
        (), description="intervals [t_start, t_end) of sequence time without GPS fixes [s]"
    )
    gps_outlier_fraction: float = Field(0.0, ge=0, le=1, description="probability that a GPS fix is an outlier")
    gps_outlier_magnitude: float = Field(10.0, ge=0, description="displacement of a GPS outlier, random direction [m]")
    slip: tuple[SlipEpisode, ...] = Field(
        (),
        description="slip episodes (t_start [s], t_end [s], factor) or (t_start, t_end, left, right): ground/wheel speed ratios",
    )
    motion_source: Literal["cmd_vel", "odometry"] = Field(
        "cmd_vel", description="Sequence.motion: the commands or the wheel odometry"
    )
    v_mean: float = Field(1.0, description="mean commanded speed [m/s]")
    v_amplitude: float = Field(0.5, ge=0, description="amplitude of the commanded speed's variation [m/s]")
    omega_amplitude: float = Field(0.4, ge=0, description="amplitude of the commanded turn rate [rad/s]")
    ramp: float = Field(2.0, ge=0, description="fade-in of the commands from rest [s]")
    wheel_base: float = Field(0.5, gt=0, description="track width b [m]")
    actuator_tau: float = Field(0.1, ge=0, description="time constant τ of the wheels' first-order lag [s]; 0: no lag")
    actuator_sigma: float = Field(
        0.02, ge=0, description="stationary std of the executed wheel speed around the lagged command [m/s]"
    )
    encoder_sigma: float = Field(2e-4, ge=0, description="std of the encoder noise per wheel per row [m]")
    substeps: int = Field(10, ge=1, description="fine integration steps per command row")
    start: tuple[float, float, float] = Field((0.0, 0.0, 0.0), description="start pose (x [m], y [m], θ [rad])")
    t0: float = Field(0.0, description="first stamp [s]")
    seed: int = Field(
        0, ge=0, description="seed of numpy.random.SeedSequence (profile, actuators, encoders, GPS, outliers, IMU)"
    )

    @model_validator(mode="after")
    def _whole_steps(self):
        if self.duration * self.cmd_rate < 1 or self.cmd_rate * self.substeps < 1:
            raise ValueError(
                f"duration × cmd_rate ({self.duration * self.cmd_rate:g}) and cmd_rate × substeps "
                f"({self.cmd_rate * self.substeps:g}) must be ≥ 1: at least one command row, fine steps of at most 1 s"
            )
        return self

    @model_validator(mode="after")
    def _fits_in_memory(self):
        """The run's arrays must fit in the memory available (:func:`slamarena.resources.require_memory`): duration ×
        cmd_rate × substeps fine steps (≈ 128 B each: the true state, wheel speeds, working copies) and the GPS and
        IMU rows (64 B each)."""
        fine = self.duration * self.cmd_rate * self.substeps
        rows = self.duration * (self.cmd_rate + self.gps_rate + self.imu_rate)
        require_memory(
            fine * 128.0 + rows * 64.0,
            f"duration = {self.duration:g} s at cmd_rate = {self.cmd_rate:g} Hz × substeps = {self.substeps} "
            f"makes {fine:.3g} fine steps",
        )
        return self


@with_params(LocalizationWorldParams)
def simulate(*, params: LocalizationWorldParams) -> Sequence:
    """Simulate one run of the localization world (:class:`LocalizationWorldParams`; the model is in the module docstring)."""
    p = params
    start = np.asarray(p.start, dtype=float)

    streams = np.random.SeedSequence(p.seed).spawn(6)
    rng_profile, rng_actuator, rng_encoder, rng_gps, rng_outlier, rng_imu = (np.random.default_rng(s) for s in streams)

    # ---------------------------------------------------------------- commands, rows t_k
    T = 1.0 / p.cmd_rate
    K = int(round(p.duration * p.cmd_rate))
    t = p.t0 + T * np.arange(K + 1)
    v_c, w_c = command_profile(rng_profile, t[:K] - p.t0, p.v_mean, p.v_amplitude, p.omega_amplitude, p.ramp)

    # ---------------------------------------------------------------- actuators on the fine grid
    m = p.substeps
    h = T / m
    half_b = 0.5 * p.wheel_base
    c = np.repeat(np.column_stack([v_c - w_c * half_b, v_c + w_c * half_b]), m, axis=0)  # (K m, 2) left, right
    a = math.exp(-h / p.actuator_tau) if p.actuator_tau > 0 else 0.0
    drive = (1.0 - a) * c + p.actuator_sigma * math.sqrt(1.0 - a * a) * rng_actuator.standard_normal(c.shape)
    wheel = first_order_response(drive, a, np.zeros(2))  # executed wheel speeds at the fine stamps
    # executed wheel travel per substep (K m, 2): the exact mean of the lag response over the substep
    if p.actuator_tau > 0:
        travel = h * (c + (1.0 - a) * p.actuator_tau / h * (wheel[:-1] - c))
    else:
        travel = h * wheel[1:]  # no lag: w_{n+1} = c_n + σ ξ_n runs through substep n
    t_fine = p.t0 + h * np.arange(K * m + 1)
    ground = travel * _slip_factors(0.5 * (t_fine[:-1] + t_fine[1:]), p.slip)
    v_true = (ground[:, 1] + ground[:, 0]) / (2.0 * h)
    w_true = (ground[:, 1] - ground[:, 0]) / (p.wheel_base * h)
    fine = kinematics.integrate("arc", start, v_true, w_true, np.full(K * m, h))

    # ---------------------------------------------------------------- wheel odometry per row
    d = travel.reshape(K, m, 2).sum(axis=1) + p.encoder_sigma * rng_encoder.standard_normal((K, 2))
    v_o = (d[:, 1] + d[:, 0]) / (2.0 * T)
    w_o = (d[:, 1] - d[:, 0]) / (p.wheel_base * T)
    v_in, w_in = (v_c, w_c) if p.motion_source == "cmd_vel" else (v_o, w_o)
    motion = Twist(t=t[:K], v=v_in, omega=w_in, dt=np.full(K, T))

    # ---------------------------------------------------------------- the input's error per second
    error = np.column_stack([np.repeat(v_in, m) - v_true, np.repeat(w_in, m) - w_true]) * h
    per_window = int(round(1.0 / h))
    windows = error[: (error.shape[0] // per_window) * per_window].reshape(-1, per_window, 2).sum(axis=1)
    psd = windows.T @ windows / windows.shape[0] / (per_window * h)

    # ---------------------------------------------------------------- GPS and IMU
    t_gps = _stamps(p.t0, t_fine[-1], p.gps_rate)
    available = np.ones(t_gps.size, dtype=bool)
    for t_a, t_b in p.gps_outages:
        available &= ~((t_gps >= t_a) & (t_gps < t_b))
    t_gps = t_gps[available]
    xy = interpolate_poses(t_fine, fine, t_gps)[:, :2] + p.gps_sigma * rng_gps.standard_normal((t_gps.size, 2))
    outlier = rng_outlier.uniform(size=t_gps.size) < p.gps_outlier_fraction
    direction = rng_outlier.uniform(0.0, 2.0 * np.pi, t_gps.size)
    xy[outlier] += p.gps_outlier_magnitude * np.column_stack([np.cos(direction), np.sin(direction)])[outlier]
    t_imu = _stamps(p.t0, t_fine[-1], p.imu_rate)
    yaw = wrap_angle(
        interpolate_poses(t_fine, fine, t_imu)[:, 2]
        + p.imu_bias
        + math.sqrt(p.imu_var) * rng_imu.standard_normal(t_imu.size)
    )

    meta = dict(
        dataset="sim:localization",
        **p.canonical(),
        twist_psd=psd.tolist(),
        twist_psd_unit="[(m/s)^2 s, (m/s)(rad/s) s; ., (rad/s)^2 s]: covariance of the input error integrated over 1 s, per second",
        gps_outlier_index=np.flatnonzero(outlier).tolist(),
        encoder_twist_cov=[
            [p.encoder_sigma**2 / (2 * T * T), 0.0],
            [0.0, 2 * p.encoder_sigma**2 / (p.wheel_base * T) ** 2],
        ],
    )
    return Sequence(
        name=f"sim:localization({p.motion_source},seed={p.seed})",
        motion=motion,
        gps=Gps(t=t_gps, xy=xy),
        heading=Heading(t=t_imu, yaw=yaw),
        ground_truth=Trajectory(t=t, poses=fine[::m]),
        initial_pose=start,
        noise=Noise(twist_cov=psd / T, gps_cov=p.gps_sigma**2 * np.eye(2), yaw_var=float(p.imu_var)),
        meta=meta,
    )
