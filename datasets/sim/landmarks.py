"""``sim:landmarks`` — a landmark world for EKF-SLAM: (v, ω) commands, range-bearing observations.

World
-----
The robot drives laps of a closed **route**: a rounded rectangle, i.e. the points at distance
``r`` (the turning radius) from a core rectangle ``[−a, a] × [−b, b]`` centred on the origin.
Landmarks lie in the **band** of points whose distance to the route is in
``[clearance, band]`` (both sides of the route), so every landmark can be seen and the
robot never drives over one. The world scales with the landmark count: the band has area
``≈ 2 (band − clearance) · P`` for a route of length ``P``, and ``P`` is chosen so that
``n_landmarks / area = density`` (landmarks per m²). With the defaults (50 landmarks,
0.05 /m²) the route is ≈ 71 m long; 2000 landmarks at ``density=1`` give a ≈ 143 m route
with ≈ 150 landmarks in sensor range (cap them with ``max_observations``).

Layouts: ``"random"`` — uniform in the band (rejection sampling); ``"grid"`` — the nodes
of a square lattice (spacing ≈ 1/√density) inside the band, the ``n`` nearest the route;
``"ring"`` — posts along both sides of the route at lateral offsets ±(clearance + band)/2,
evenly spaced in route arclength, alternating sides.

Motion
------
True controls per lap: long straight, quarter turn, short straight, quarter turn, repeated
twice. Straights run at ``speed``; a turn holds ``ω = (π/2) / (n_turn dt)`` with
``v = ω r`` for an integer number of steps, so every turn is exactly π/2 and the loop closes
exactly for either motion model (a rigid motion of rotation π composed with itself is the
identity). The truth is ``x_{k+1} = x_k ⊕ δ(u_k, dt)`` with
``slamarena.datasets.kinematics`` with model ``motion_model`` (default ``"arc"``, the exact
constant-twist step). The estimator sees the noisy controls
``ũ_k = u_k + ε_k, ε_k ~ N(0, diag(σ_v², σ_ω²))``, one draw per row, held constant for the
row's ``dt`` (``Noise.twist_cov`` is the covariance of a row's velocity error, not a
spectral density: the pose error of one row is ``V Σ Vᵀ`` with ``V = ∂x'/∂u`` at that ``dt``).

Sensor and stamping
-------------------
Rows: ``Twist`` row ``k`` has stamp ``t_k = t0 + k·dt`` and holds ``ũ_k`` on ``[t_k, t_{k+1})``.
Ground truth holds the true pose at every ``t_k``, ``k = 0 … K`` (``K + 1`` poses, ``t0`` and
the end of the last row included). The observation set of step ``k`` is taken from the
true pose at ``t_{k+1}`` — AFTER row ``k``'s motion — and stamped ``t_{k+1}``; there is none
at ``t0``. A filter walking ``Sequence.events()`` therefore predicts to the stamp
(motion events come first at equal stamps) and then updates with the whole set. Steps
with no landmark in view have no rows.

Visibility uses the true range and bearing: ``range ≤ max_range`` and
``|bearing| ≤ fov/2`` (``fov`` is the full field of view; ``2π`` sees all round). With
``max_observations = m`` only ``m`` visible landmarks are reported: the ``m`` nearest
(``observation_choice="nearest"``), or ``m`` drawn uniformly at random (``"random"``, its own
seeded stream: a world whose far landmarks the nearest few would always hide is still mapped
whole, so the map size is the ``n`` a cost study sweeps). Within a set rows are ordered nearest first. Observations are ``z = h(x, m) + η``,
``η ~ N(0, diag(σ_r², σ_b²))``, bearing wrapped to (−π, π]; ``landmark_id`` is the true id
(``0 … n−1``; a consumer may withhold it). Ranges are not clipped (the clearance keeps them
well above zero).

Randomness: ``numpy.random.SeedSequence(seed)`` is split into independent streams for the
landmarks, the control noise, the observation noise and the random choice of observations, so e.g. changing the sensor noise
leaves the landmarks and the odometry of a seed unchanged.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import ConfigDict, PositiveInt, model_validator

from slamarena.params import Field, Params, with_params
from slamarena.resources import require_memory

from .. import kinematics
from ..geometry import wrap_angle
from ..sequence import LandmarkMap, Noise, RangeBearing, Sequence, Trajectory, Twist

__all__ = ["simulate", "LandmarkWorldParams", "LAYOUTS", "route_distance"]

#: steps × landmarks evaluated per block when generating observations (memory bound)
_BLOCK_ELEMENTS = 2_000_000


def route_distance(points: np.ndarray, half_a: float, half_b: float, radius: float) -> np.ndarray:
    """Distance of points (..., 2) to the route: the curve at distance ``radius`` from the core box."""
    p = np.abs(np.asarray(points, dtype=float))
    qx, qy = p[..., 0] - half_a, p[..., 1] - half_b
    outside = np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0))
    inside = np.minimum(np.maximum(qx, qy), 0.0)
    return np.abs(outside + inside - radius)


def _random_layout(rng, n, geo) -> np.ndarray:
    half_w, half_h = geo["half_a"] + geo["radius"] + geo["band"], geo["half_b"] + geo["radius"] + geo["band"]
    out = np.zeros((0, 2))
    while out.shape[0] < n:
        batch = rng.uniform([-half_w, -half_h], [half_w, half_h], size=(max(2 * n, 256), 2))
        d = route_distance(batch, geo["half_a"], geo["half_b"], geo["radius"])
        out = np.vstack([out, batch[(d >= geo["clearance"]) & (d <= geo["band"])]])
    return out[:n]


def _grid_layout(rng, n, geo) -> np.ndarray:
    half_w, half_h = geo["half_a"] + geo["radius"] + geo["band"], geo["half_b"] + geo["radius"] + geo["band"]
    spacing = 1.0 / math.sqrt(geo["density"])
    while True:
        xs = np.arange(-half_w, half_w + 1e-9, spacing)
        ys = np.arange(-half_h, half_h + 1e-9, spacing)
        nodes = np.stack(np.meshgrid(xs - xs.mean(), ys - ys.mean()), axis=-1).reshape(-1, 2)
        d = route_distance(nodes, geo["half_a"], geo["half_b"], geo["radius"])
        inside = (d >= geo["clearance"]) & (d <= geo["band"])
        if inside.sum() >= n:
            keep = np.flatnonzero(inside)
            order = np.argsort(d[keep], kind="stable")
            return nodes[keep[order[:n]]]
        spacing *= 0.95 * math.sqrt(inside.sum() / n) if inside.sum() else 0.5


def _ring_layout(rng, n, geo) -> np.ndarray:
    poses = geo["lap_poses"]
    length = np.r_[0.0, np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))]
    s = (np.arange(n) + 0.5) * length[-1] / n
    x = np.interp(s, length, poses[:, 0])
    y = np.interp(s, length, poses[:, 1])
    idx = np.clip(np.searchsorted(length, s) - 1, 0, len(poses) - 1)
    th = poses[idx, 2]
    offset = 0.5 * (geo["clearance"] + geo["band"]) * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    return np.column_stack([x - offset * np.sin(th), y + offset * np.cos(th)])


#: layout name → generator (rng, n, geometry dict) → (n, 2) positions
LAYOUTS = {"random": _random_layout, "grid": _grid_layout, "ring": _ring_layout}


def _lap_controls(
    half_a: float, half_b: float, radius: float, speed: float, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """True (v, ω) of one lap: (straight 2a, turn, straight 2b, turn) × 2."""
    n_a = max(int(round(2 * half_a / (speed * dt))), 0)
    n_b = max(int(round(2 * half_b / (speed * dt))), 0)
    n_turn = max(int(round(0.5 * math.pi * radius / (speed * dt))), 1)
    omega_turn = 0.5 * math.pi / (n_turn * dt)
    v, w = [], []
    for n_straight in (n_a, n_b, n_a, n_b):
        v += [speed] * n_straight + [omega_turn * radius] * n_turn
        w += [0.0] * n_straight + [omega_turn] * n_turn
    return np.asarray(v), np.asarray(w)


class LandmarkWorldParams(Params):
    """Parameters of :func:`simulate` (SI units, angles in radians; see the module docstring for the model)."""

    model_config = ConfigDict(allow_inf_nan=False)

    n_landmarks: int = Field(50, ge=1, description="number of landmarks n")
    layout: Literal["random", "grid", "ring"] = Field("random", description="landmark layout in the band (LAYOUTS)")
    density: float = Field(0.05, gt=0, description="landmarks per area of band [1/m²]; sets the route length")
    band: float = Field(8.0, gt=0, description="largest landmark distance to the route [m]")
    clearance: float = Field(1.0, ge=0, description="smallest landmark distance to the route [m]; < band")
    turn_radius: float = Field(
        4.0, gt=0, description="turning radius r of the route's corners [m] (smaller if the route is short)"
    )
    aspect: float = Field(1.5, gt=0, description="long straight / short straight of the route [1]")
    speed: float = Field(1.0, gt=0, description="speed on the straights [m/s]")
    laps: int = Field(1, ge=1, description="laps of the route")
    dt: float = Field(0.1, gt=0, description="duration of a control row [s]")
    motion_model: kinematics.MotionModel = Field(
        "arc", description="motion model that drives the truth (datasets.kinematics)"
    )
    sigma_v: float = Field(0.1, ge=0, description="std of a row's speed error σ_v [m/s]")
    sigma_omega: float = Field(0.05, ge=0, description="std of a row's turn-rate error σ_ω [rad/s]")
    max_range: float = Field(10.0, gt=0, description="sensor range [m]")
    fov: float = Field(
        math.pi, gt=0, le=2 * math.pi, description="full field of view, centred ahead [rad]; 2π sees all round"
    )
    sigma_range: float = Field(0.1, ge=0, description="std of the range noise σ_r [m]")
    sigma_bearing: float = Field(math.radians(1.0), ge=0, description="std of the bearing noise σ_b [rad]")
    max_observations: PositiveInt | None = Field(None, description="keep m visible landmarks per step; None: all")
    observation_choice: Literal["nearest", "random"] = Field(
        "nearest", description="which m of max_observations: the nearest, or drawn at random"
    )
    t0: float = Field(0.0, description="first stamp [s]")
    seed: int = Field(
        0, ge=0, description="seed of numpy.random.SeedSequence (landmarks, control noise, observation noise)"
    )

    @model_validator(mode="after")
    def _clearance_below_band(self):
        if self.clearance >= self.band:
            raise ValueError(f"clearance ({self.clearance}) must be < band ({self.band})")
        return self

    @model_validator(mode="after")
    def _fits_in_memory(self):
        """The run's arrays must fit in the memory available (:func:`slamarena.resources.require_memory`): a route of
        P = n / (2 density (band − clearance)) metres walked ``laps`` times at ``speed`` is K ≈ laps P / (speed dt)
        steps, each seeing ≈ V = min(n, max_observations, density · (fov / 2) · max_range²) landmarks (the sensor's
        sector); 16 B a landmark, 128 B a step (controls, truth, noise, working copies), 96 B an observation."""
        if self.clearance >= self.band:
            return self
        n = self.n_landmarks
        steps = self.laps * n / (2 * self.density * (self.band - self.clearance)) / (self.speed * self.dt)
        seen = min(n, self.max_observations or n, self.density * 0.5 * self.fov * self.max_range**2)
        require_memory(
            16.0 * n + steps * (128.0 + 96.0 * seen),
            f"n_landmarks = {n} with laps = {self.laps}, density = {self.density:g} /m², speed · dt = "
            f"{self.speed * self.dt:g} m makes a run of ≈ {steps:.3g} steps seeing ≈ {seen:.3g} landmarks each",
        )
        return self


@with_params(LandmarkWorldParams)
def simulate(*, params: LandmarkWorldParams) -> Sequence:
    """Simulate one run of the landmark world (:class:`LandmarkWorldParams`; the model is in the module docstring)."""
    p = params
    n, density, band, clearance, speed, dt = p.n_landmarks, p.density, p.band, p.clearance, p.speed, p.dt

    # ---------------------------------------------------------------- route from n and density
    perimeter = n / (density * 2.0 * (band - clearance))
    radius = min(p.turn_radius, perimeter / (4.0 * math.pi))
    straights = (perimeter - 2.0 * math.pi * radius) / 2.0  # = 2a + 2b
    half_b = straights / (2.0 * (1.0 + p.aspect))
    half_a = p.aspect * half_b
    v_lap, w_lap = _lap_controls(half_a, half_b, radius, speed, dt)
    # the realised core box (straights are whole numbers of steps)
    n_a = int(round(2 * half_a / (speed * dt)))
    n_b = int(round(2 * half_b / (speed * dt)))
    half_a, half_b = 0.5 * n_a * speed * dt, 0.5 * n_b * speed * dt
    start = np.array([-half_a, -half_b - radius, 0.0])
    dts_lap = np.full(v_lap.size, float(dt))

    ss_landmarks, ss_controls, ss_obs, ss_choice = np.random.SeedSequence(p.seed).spawn(
        4
    )  # the first three as with spawn(3)
    geo = dict(
        half_a=half_a,
        half_b=half_b,
        radius=radius,
        band=band,
        clearance=clearance,
        density=density,
        lap_poses=kinematics.integrate(p.motion_model, start, v_lap, w_lap, dts_lap),
    )
    xy = LAYOUTS[p.layout](np.random.default_rng(ss_landmarks), n, geo)

    # ---------------------------------------------------------------- controls and truth
    v = np.tile(v_lap, p.laps)
    w = np.tile(w_lap, p.laps)
    K = v.size
    t = p.t0 + dt * np.arange(K + 1)
    truth = kinematics.integrate(p.motion_model, start, v, w, np.full(K, float(dt)))
    eps = np.random.default_rng(ss_controls).standard_normal((K, 2)) * [p.sigma_v, p.sigma_omega]
    motion = Twist(t=t[:K], v=v + eps[:, 0], omega=w + eps[:, 1], dt=np.full(K, float(dt)))

    # ---------------------------------------------------------------- observations (poses 1..K)
    rows_step, rows_id, rows_r, rows_b = [], [], [], []
    choice_rng = np.random.default_rng(ss_choice)
    block = max(1, _BLOCK_ELEMENTS // n)
    for lo in range(1, K + 1, block):
        x = truth[lo : lo + block]
        r = np.hypot(xy[None, :, 0] - x[:, None, 0], xy[None, :, 1] - x[:, None, 1])
        step, lm = np.nonzero(r <= p.max_range)
        rr = r[step, lm]
        bb = wrap_angle(np.arctan2(xy[lm, 1] - x[step, 1], xy[lm, 0] - x[step, 0]) - x[step, 2])
        in_fov = np.abs(bb) <= 0.5 * p.fov
        step, lm, rr, bb = step[in_fov], lm[in_fov], rr[in_fov], bb[in_fov]
        order = np.lexsort((lm, rr, step))  # by step, then nearest first
        step, lm, rr, bb = step[order], lm[order], rr[order], bb[order]
        if p.max_observations is not None:
            if (
                p.observation_choice == "random"
            ):  # rank each step's rows by a random key, keep m, then nearest first again
                shuffle = np.lexsort((choice_rng.random(step.size), step))
                step, lm, rr, bb = step[shuffle], lm[shuffle], rr[shuffle], bb[shuffle]
            first = np.flatnonzero(np.r_[True, step[1:] != step[:-1]])
            rank = np.arange(step.size) - np.repeat(first, np.diff(np.r_[first, step.size]))
            keep = rank < p.max_observations
            step, lm, rr, bb = step[keep], lm[keep], rr[keep], bb[keep]
            if p.observation_choice == "random":
                order = np.lexsort((lm, rr, step))
                step, lm, rr, bb = step[order], lm[order], rr[order], bb[order]
        rows_step.append(lo + step)
        rows_id.append(lm)
        rows_r.append(rr)
        rows_b.append(bb)
    step = np.concatenate(rows_step)
    ids = np.concatenate(rows_id)
    eta = np.random.default_rng(ss_obs).standard_normal((step.size, 2)) * [p.sigma_range, p.sigma_bearing]
    range_bearing = RangeBearing(
        t=t[step],
        range=np.concatenate(rows_r) + eta[:, 0],
        bearing=wrap_angle(np.concatenate(rows_b) + eta[:, 1]),
        landmark_id=ids,
    )

    extent = [half_a + radius + band, half_b + radius + band]
    meta = dict(
        dataset="sim:landmarks",
        **p.canonical(),
        route=dict(
            half_a=half_a,
            half_b=half_b,
            turn_radius=radius,
            length=float(v_lap.sum() * dt),
            steps_per_lap=int(v_lap.size),
        ),
        world_extent=[-extent[0], -extent[1], extent[0], extent[1]],
        steps=int(K),
        observation_stamping="set k is the true pose at t_{k+1}, after Twist row k; no set at t0",
    )
    return Sequence(
        name=f"sim:landmarks(n={n},layout={p.layout},seed={p.seed})",
        motion=motion,
        range_bearing=range_bearing,
        ground_truth=Trajectory(t=t, poses=truth),
        landmarks=LandmarkMap(ids=np.arange(n), xy=xy),
        initial_pose=start,
        noise=Noise(
            twist_cov=np.diag([p.sigma_v**2, p.sigma_omega**2]),
            range_bearing_cov=np.diag([p.sigma_range**2, p.sigma_bearing**2]),
        ),
        meta=meta,
    )
