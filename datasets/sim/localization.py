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

import numpy as np

from .. import kinematics
from ..geometry import interpolate_poses, wrap_angle
from ..sequence import Gps, Heading, Noise, Sequence, Trajectory, Twist

__all__ = ["simulate", "MOTION_SOURCES", "command_profile", "first_order_response"]

MOTION_SOURCES = ("cmd_vel", "odometry")


def command_profile(rng: np.random.Generator, t: np.ndarray, v_mean: float, v_amplitude: float, omega_amplitude: float, ramp: float) -> tuple[np.ndarray, np.ndarray]:
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
        chunk = u[s:s + block]
        B = chunk.shape[0]
        scaled = np.cumsum(chunk / powers[1:B + 1, None], axis=0)
        w[s + 1:s + B + 1] = powers[1:B + 1, None] * (w[s] + scaled)
    return w


def _slip_factors(t_mid: np.ndarray, slip) -> np.ndarray:
    """Ground/wheel speed ratio (N, 2) of the left and right wheel at times ``t_mid``."""
    f = np.ones((t_mid.size, 2))
    for episode in slip:
        if len(episode) == 3:
            t_a, t_b, left = episode
            right = left
        elif len(episode) == 4:
            t_a, t_b, left, right = episode
        else:
            raise ValueError(f"slip episode {episode!r}: expected (t_start, t_end, factor) or (t_start, t_end, left, right)")
        if not (t_b > t_a and 0.0 <= left and 0.0 <= right):
            raise ValueError(f"slip episode {episode!r}: need t_end > t_start and factors >= 0")
        inside = (t_mid >= t_a) & (t_mid < t_b)
        f[inside] *= [left, right]
    return f


def _stamps(t0: float, t_end: float, rate: float) -> np.ndarray:
    """Sensor stamps ``t0 + j/rate`` within ``[t0, t_end]`` (a last stamp within rounding of ``t_end`` is kept, clipped)."""
    stamps = t0 + np.arange(int(math.floor((t_end - t0) * rate + 1e-9)) + 1) / rate
    return np.minimum(stamps, t_end)


def simulate(
    duration: float = 120.0,
    cmd_rate: float = 50.0,
    gps_rate: float = 5.0,
    imu_rate: float = 50.0,
    gps_sigma: float = 0.01,
    imu_var: float = 0.001,
    imu_bias: float = 0.0,
    gps_outages=(),
    gps_outlier_fraction: float = 0.0,
    gps_outlier_magnitude: float = 10.0,
    slip=(),
    motion_source: str = "cmd_vel",
    v_mean: float = 1.0,
    v_amplitude: float = 0.5,
    omega_amplitude: float = 0.4,
    ramp: float = 2.0,
    wheel_base: float = 0.5,
    actuator_tau: float = 0.1,
    actuator_sigma: float = 0.02,
    encoder_sigma: float = 2e-4,
    substeps: int = 10,
    start=(0.0, 0.0, 0.0),
    t0: float = 0.0,
    seed: int = 0,
) -> Sequence:
    """Simulate one run of the localization world (see the module docstring for the model).

    Units: seconds, metres, radians; rates in Hz. ``gps_outages`` is a list of
    ``(t_start, t_end)`` in sequence time; ``slip`` a list of ``(t_start, t_end, factor)`` or
    ``(t_start, t_end, left, right)`` ground/wheel speed ratios.
    """

    if motion_source not in MOTION_SOURCES:
        raise ValueError(f"unknown motion_source {motion_source!r}; choose from {MOTION_SOURCES}")
    for name, value in dict(duration=duration, cmd_rate=cmd_rate, gps_rate=gps_rate, imu_rate=imu_rate, wheel_base=wheel_base).items():
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    for name, value in dict(gps_sigma=gps_sigma, imu_var=imu_var, actuator_tau=actuator_tau, actuator_sigma=actuator_sigma,
                            encoder_sigma=encoder_sigma, gps_outlier_magnitude=gps_outlier_magnitude, ramp=ramp, v_amplitude=v_amplitude,
                            omega_amplitude=omega_amplitude).items():
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if not 0.0 <= gps_outlier_fraction <= 1.0:
        raise ValueError(f"gps_outlier_fraction must be in [0, 1], got {gps_outlier_fraction!r}")
    if int(substeps) < 1:
        raise ValueError("substeps must be >= 1")
    if duration < 1.0:
        raise ValueError("duration must be >= 1 s (the input noise is measured over 1-s windows)")
    outages = [tuple(map(float, o)) for o in gps_outages]
    if any(len(o) != 2 or not o[1] > o[0] for o in outages):
        raise ValueError(f"gps_outages must be (t_start, t_end) pairs with t_end > t_start, got {gps_outages!r}")
    slip = [tuple(map(float, e)) for e in slip]
    start = np.asarray(start, dtype=float).reshape(3)

    streams = np.random.SeedSequence(int(seed)).spawn(6)
    rng_profile, rng_actuator, rng_encoder, rng_gps, rng_outlier, rng_imu = (np.random.default_rng(s) for s in streams)

    # ---------------------------------------------------------------- commands, rows t_k
    T = 1.0 / cmd_rate
    K = int(round(duration * cmd_rate))
    t = t0 + T * np.arange(K + 1)
    v_c, w_c = command_profile(rng_profile, t[:K] - t0, v_mean, v_amplitude, omega_amplitude, ramp)

    # ---------------------------------------------------------------- actuators on the fine grid
    m = int(substeps)
    h = T / m
    half_b = 0.5 * wheel_base
    c = np.repeat(np.column_stack([v_c - w_c * half_b, v_c + w_c * half_b]), m, axis=0)  # (K m, 2) left, right
    a = math.exp(-h / actuator_tau) if actuator_tau > 0 else 0.0
    drive = (1.0 - a) * c + actuator_sigma * math.sqrt(1.0 - a * a) * rng_actuator.standard_normal(c.shape)
    wheel = first_order_response(drive, a, np.zeros(2))  # executed wheel speeds at the fine stamps
    # executed wheel travel per substep (K m, 2): the exact mean of the lag response over the substep
    if actuator_tau > 0:
        travel = h * (c + (1.0 - a) * actuator_tau / h * (wheel[:-1] - c))
    else:
        travel = h * wheel[1:]  # no lag: w_{n+1} = c_n + σ ξ_n runs through substep n
    t_fine = t0 + h * np.arange(K * m + 1)
    ground = travel * _slip_factors(0.5 * (t_fine[:-1] + t_fine[1:]), slip)
    v_true = (ground[:, 1] + ground[:, 0]) / (2.0 * h)
    w_true = (ground[:, 1] - ground[:, 0]) / (wheel_base * h)
    fine = kinematics.integrate("arc", start, v_true, w_true, np.full(K * m, h))

    # ---------------------------------------------------------------- wheel odometry per row
    d = travel.reshape(K, m, 2).sum(axis=1) + encoder_sigma * rng_encoder.standard_normal((K, 2))
    v_o = (d[:, 1] + d[:, 0]) / (2.0 * T)
    w_o = (d[:, 1] - d[:, 0]) / (wheel_base * T)
    v_in, w_in = (v_c, w_c) if motion_source == "cmd_vel" else (v_o, w_o)
    motion = Twist(t=t[:K], v=v_in, omega=w_in, dt=np.full(K, T))

    # ---------------------------------------------------------------- the input's error per second
    error = np.column_stack([np.repeat(v_in, m) - v_true, np.repeat(w_in, m) - w_true]) * h
    per_window = int(round(1.0 / h))
    windows = error[: (error.shape[0] // per_window) * per_window].reshape(-1, per_window, 2).sum(axis=1)
    psd = windows.T @ windows / windows.shape[0] / (per_window * h)

    # ---------------------------------------------------------------- GPS and IMU
    t_gps = _stamps(t0, t_fine[-1], gps_rate)
    available = np.ones(t_gps.size, dtype=bool)
    for t_a, t_b in outages:
        available &= ~((t_gps >= t_a) & (t_gps < t_b))
    t_gps = t_gps[available]
    xy = interpolate_poses(t_fine, fine, t_gps)[:, :2] + gps_sigma * rng_gps.standard_normal((t_gps.size, 2))
    outlier = rng_outlier.uniform(size=t_gps.size) < gps_outlier_fraction
    direction = rng_outlier.uniform(0.0, 2.0 * np.pi, t_gps.size)
    xy[outlier] += gps_outlier_magnitude * np.column_stack([np.cos(direction), np.sin(direction)])[outlier]
    t_imu = _stamps(t0, t_fine[-1], imu_rate)
    yaw = wrap_angle(interpolate_poses(t_fine, fine, t_imu)[:, 2] + imu_bias + math.sqrt(imu_var) * rng_imu.standard_normal(t_imu.size))

    params = dict(duration=duration, cmd_rate=cmd_rate, gps_rate=gps_rate, imu_rate=imu_rate, gps_sigma=gps_sigma, imu_var=imu_var,
                  imu_bias=imu_bias, gps_outages=[list(o) for o in outages], gps_outlier_fraction=gps_outlier_fraction,
                  gps_outlier_magnitude=gps_outlier_magnitude, slip=[list(e) for e in slip], motion_source=motion_source,
                  v_mean=v_mean, v_amplitude=v_amplitude, omega_amplitude=omega_amplitude, ramp=ramp, wheel_base=wheel_base,
                  actuator_tau=actuator_tau, actuator_sigma=actuator_sigma, encoder_sigma=encoder_sigma, substeps=m,
                  start=start.tolist(), t0=t0, seed=int(seed))
    meta = dict(
        dataset="sim:localization",
        **params,
        twist_psd=psd.tolist(),
        twist_psd_unit="[(m/s)^2 s, (m/s)(rad/s) s; ., (rad/s)^2 s]: covariance of the input error integrated over 1 s, per second",
        gps_outlier_index=np.flatnonzero(outlier).tolist(),
        encoder_twist_cov=[[encoder_sigma**2 / (2 * T * T), 0.0], [0.0, 2 * encoder_sigma**2 / (wheel_base * T) ** 2]],
    )
    return Sequence(
        name=f"sim:localization({motion_source},seed={int(seed)})",
        motion=motion,
        gps=Gps(t=t_gps, xy=xy),
        heading=Heading(t=t_imu, yaw=yaw),
        ground_truth=Trajectory(t=t, poses=fine[::m]),
        initial_pose=start,
        noise=Noise(twist_cov=psd / T, gps_cov=gps_sigma**2 * np.eye(2), yaw_var=float(imu_var)),
        meta=meta,
    )
