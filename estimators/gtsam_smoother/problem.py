"""The landmark-SLAM smoothing problem of a ``Sequence``, as arrays (numpy only; no GTSAM here).

Parameters: :class:`PoseChainParams` (the motion model, the relative motions' noise and the prior on the
first pose; every sequence smoother extends it) and :class:`LandmarkProblemParams` (adds the extra pose
keys, the odometry increments', observations' and beacon ranges' noise).

Pose keys
    One pose key at the start of the motion, at every observation set with a known landmark
    id, every ``max_interval`` seconds if given, and at the end of the motion. Keys with no
    motion between them (no command in force, no increment) are the same pose.
Relative motion (pose k−1 → k)
    ``delta[k−1]`` (3,): the dead-reckoned relative pose, and ``cov[k−1]`` (3, 3): its
    covariance in GTSAM's right-perturbation (body) coordinates ``Jᵀ P_δ J`` — see
    :mod:`.noise`. P_δ comes from the filters' own propagation of the motion noise
    (``Noise.twist_cov`` through the motion model's V, or the increments' covariance).
Observations
    ``obs_pose`` (N,) pose index, ``obs_id`` (N,), ``obs_range``, ``obs_bearing`` (N,), the stated noise
    ``R = Noise.range_bearing_cov`` (2, 2) in (range, bearing) order and each observation's ``obs_cov`` (N, 2, 2): R, or
    ``diag(σ², σ²/r_j²)`` with σ² = R[0, 0] for ``range_bearing_noise="cartesian"`` (:func:`.models.observation_covariances`).
Beacon ranges (range-only, ``Sequence.beacon_ranges``)
    ``rng_pose`` (M,), ``rng_id`` (M,), ``rng_range`` (M,) with the range offset β = ``beacon_bias``
    already removed (z − β), variance ``R_range`` = ``beacon_range_var``. Beacons share the landmark id space (one
    ``LandmarkMap`` holds both); ``map_ids``/``map_xy`` are the sequence's known positions.

Rejected and counted (``counts``) before they reach a graph: motion rows, observations and ranges
that are not finite or too large to square (:func:`summable`: ``rejected_nonfinite_motion``,
``rejected_nonfinite_observations``, ``rejected_nonfinite_ranges``), odometry increments whose own
covariance is not finite, symmetric and positive semidefinite (:func:`valid_covariances`:
``rejected_invalid_cov_motion``), negative ranges as measured (``rejected_negative_range_observations``,
``rejected_negative_ranges``: before β is removed), and observations without a landmark id (``skipped_unknown_id_observations``:
this smoother uses known association only). A stated noise (a parameter or ``Sequence.noise``) that is
not a covariance is a ``ValueError`` (:func:`check_covariance`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Literal

import numpy as np

from slamarena.datasets.geometry import accumulate
from slamarena.datasets.sequence import Increments, Sequence, Twist
from slamarena.estimators.models import (
    MOTION_MODELS,
    RangeBearingNoise,
    inverse_observe,
    noise_in_force,
    observation_covariances,
)
from slamarena.params import Covariance2, Covariance3, Field, Params

from .noise import increments_relative, regularise, twist_relatives, world_to_body

__all__ = [
    "PoseChainParams",
    "LandmarkProblemParams",
    "MotionModelName",
    "LandmarkProblem",
    "MotionChain",
    "motion_chain",
    "twist_pieces_of_intervals",
    "build_problem",
    "check_covariance",
    "valid_covariances",
    "summable",
]

#: relative tolerance within which an observation stamp equals the end of the motion
_STAMP_TOL = 1e-9

#: the motion model's name; a field type because the smoothers share it with different defaults
MotionModelName = Annotated[
    Literal["arc", "euler"],
    Field(
        description="motion model of Twist input (estimators.models): exact constant-twist arc or the notes' Euler step"
    ),
]
PositiveFinite = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


class PoseChainParams(Params):
    """The chain of pose keys every sequence smoother builds (:func:`motion_chain`): the relative motions
    between the keys with their noise, and the prior on the first."""

    motion_model: MotionModelName = "arc"
    regularisation: float = Field(
        1e-4,
        ge=0.0,
        lt=1.0,
        description="floor of a between factor's covariance eigenvalues relative to its largest (noise.regularise) [1]",
    )
    prior_sigma: tuple[PositiveFinite, PositiveFinite, PositiveFinite] = Field(
        (1e-3, 1e-3, 1e-3),
        description="standard deviations (σx [m], σy [m], σθ [rad]) of the prior that holds the first pose at the start pose",
    )
    twist_cov: Covariance2 | None = Field(
        None,
        description="covariance of one Twist row's (v, ω) error [(m/s)², (rad/s)²]; None: the sequence's Noise.twist_cov",
    )


class LandmarkProblemParams(PoseChainParams):
    """The landmark-SLAM problem (:func:`build_problem`): the pose chain with extra keys and the odometry
    increments' noise, the observation noise and the beacon ranges'."""

    max_interval: PositiveFinite | None = Field(
        None,
        description="a pose key at least every this many seconds besides the measurement stamps [s]; None: keys at the stamps only",
    )
    increment_cov: Covariance3 | None = Field(
        None,
        description="covariance of one odometry increment (dx, dy, dθ) [m², m², rad²], for every row; "
        "None: the stream's Increments.cov, else the sequence's Noise.increment_cov",
    )

    range_bearing_cov: Covariance2 | None = Field(
        None,
        description="covariance of one observation in (range, bearing) order [m², rad²]; None: the sequence's Noise.range_bearing_cov",
    )
    range_bearing_noise: RangeBearingNoise = Field(
        RangeBearingNoise.POLAR,
        description="'polar': R for every observation; 'cartesian': the sensor noise is isotropic σ² I in the plane, "
        "R_j = diag(σ², σ²/r_j²) with σ² = R[0, 0] [m²] and r_j the range [m] (as the filters' option)",
    )
    beacon_range_var: PositiveFinite = Field(
        1.0, description="variance σ_r² of one beacon range [m²] (no dataset states it)"
    )
    beacon_bias: float = Field(
        0.0, allow_inf_nan=False, description="offset β of every beacon range, subtracted from it [m]"
    )


@dataclass(frozen=True)
class LandmarkProblem:
    t: np.ndarray
    start: np.ndarray
    delta: np.ndarray
    cov: np.ndarray
    obs_pose: np.ndarray
    obs_id: np.ndarray
    obs_range: np.ndarray
    obs_bearing: np.ndarray
    R: np.ndarray
    obs_cov: np.ndarray
    rng_pose: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    rng_id: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    rng_range: np.ndarray = field(default_factory=lambda: np.zeros(0))
    R_range: float = 1.0
    map_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    map_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    counts: dict = field(default_factory=dict)

    @property
    def n_poses(self) -> int:
        return int(self.t.shape[0])

    def dead_reckoning(self) -> np.ndarray:
        """Poses (K, 3) composed from the start along the relative motions."""
        return accumulate(self.start, self.delta)

    def observation_slices(self) -> list[slice]:
        """Rows of the observations of each pose (observations are sorted by pose)."""
        return _slices(self.obs_pose, self.n_poses)

    def range_slices(self) -> list[slice]:
        """Rows of the beacon ranges of each pose (sorted by pose)."""
        return _slices(self.rng_pose, self.n_poses)

    @property
    def landmark_ids(self) -> np.ndarray:
        """Every landmark or beacon the problem observes, sorted."""
        return np.union1d(self.obs_id, self.rng_id)

    def known_positions(self, ids: np.ndarray) -> np.ndarray:
        """Mask of ``ids`` whose position the sequence's map gives."""
        return np.isin(ids, self.map_ids)

    def map_position(self, j: int) -> np.ndarray:
        return self.map_xy[np.flatnonzero(self.map_ids == j)[0]]

    def trilaterate(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Beacon ids (B,) and positions (B, 2) from their ranges seen at ``poses`` (linear least squares).

        ‖p_i − b‖² = r_i² for every range i of a beacon; subtracting the mean equation removes
        ‖b‖²:  2 (p_i − p̄)ᵀ b = ‖p_i‖² − mean‖p‖² − (r_i² − mean r²)  — one 2×2 solve per beacon.
        A beacon seen only from (nearly) collinear positions is ambiguous by a reflection about
        that line; the least-squares solve then returns its minimum-norm point.
        """
        ids = np.unique(self.rng_id)
        xy = np.zeros((ids.size, 2))
        for n, j in enumerate(ids):
            rows = self.rng_id == j
            p = poses[self.rng_pose[rows], :2]
            r2 = self.rng_range[rows] ** 2
            q = np.sum(p**2, axis=1)
            A = 2.0 * (p - p.mean(axis=0))
            xy[n] = np.linalg.lstsq(A, (q - q.mean()) - (r2 - r2.mean()), rcond=None)[0]
        return ids, xy

    def first_sightings(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Landmark ids (L,) and initial positions (L, 2) from each landmark's first observation."""
        ids, first = np.unique(self.obs_id, return_index=True)
        z = np.column_stack([self.obs_range[first], self.obs_bearing[first]])
        return ids, inverse_observe(poses[self.obs_pose[first]], z)


def _slices(pose_of_row: np.ndarray, n_poses: int) -> list[slice]:
    bounds = np.searchsorted(pose_of_row, np.arange(n_poses + 1))
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def summable(*columns: np.ndarray) -> np.ndarray:
    """Mask of the rows whose values are finite and have finite squares, so that a sum of squared errors can
    hold them (a range of 1e300 m is finite, its square is not); each column is (N,) or (N, d)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.logical_and.reduce([np.isfinite(np.square(c)).reshape(len(c), -1).all(axis=1) for c in columns])


def valid_covariances(C: np.ndarray) -> np.ndarray:
    """Mask of the matrices of ``C`` (..., d, d) that are finite, symmetric and positive semidefinite
    (eigenvalues ≥ −1e-12 of the largest entry: round-off of a semidefinite zero is not negative)."""
    C = np.asarray(C, dtype=float)
    finite = np.isfinite(C).all(axis=(-2, -1))
    C = np.where(finite[..., None, None], C, 0.0)
    symmetric = np.isclose(C, np.swapaxes(C, -1, -2)).all(axis=(-2, -1))
    scale = np.maximum(1.0, np.abs(C).max(axis=(-2, -1)))
    return finite & symmetric & (np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))[..., 0] >= -1e-12 * scale)


def check_covariance(name: str, C, shape: tuple[int, ...]) -> np.ndarray:
    """A finite, symmetric positive-semidefinite covariance of the given shape, or ValueError."""
    C = np.asarray(C, dtype=float)
    if C.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {C.shape}")
    if not np.isfinite(C).all():
        raise ValueError(f"{name} has non-finite entries")
    if not valid_covariances(C):
        raise ValueError(f"{name} is not symmetric positive semidefinite")
    return C


def _motion_span(motion: Twist | Increments) -> tuple[float, float]:
    """Start and end time of the motion. An increment is the motion up to its stamp, so the first
    one starts a (median) period before its stamp: the start pose is the pose before every increment."""
    if isinstance(motion, Twist):
        return float(motion.t[0]), float(np.max(motion.t + motion.dt))
    gaps = np.diff(motion.t)
    period = float(np.median(gaps[gaps > 0])) if np.any(gaps > 0) else 1.0
    return float(motion.t[0]) - period, float(motion.t[-1])


@dataclass(frozen=True)
class MotionChain:
    """Pose keys at ``t`` (K,) linked by relative motions ``delta`` (K−1, 3) with body-frame ``cov``."""

    t: np.ndarray
    start: np.ndarray
    delta: np.ndarray
    cov: np.ndarray
    stamps: np.ndarray
    pose_of_stamp: np.ndarray
    counts: dict

    def index(self, t: np.ndarray) -> np.ndarray:
        """Pose index of each time in ``t`` (which must be among the requested stamps)."""
        return self.pose_of_stamp[np.searchsorted(self.stamps, t)]

    def inside(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Times snapped to the motion's end where they differ from it by rounding, and the mask of those
        within the motion's span."""
        t_end = self.stamps[-1]
        snapped = np.where(np.abs(t - t_end) <= _STAMP_TOL * max(1.0, abs(t_end)), t_end, t)
        return snapped, (snapped >= self.stamps[0]) & (snapped <= t_end)


def twist_pieces_of_intervals(twist: Twist, key_t: np.ndarray) -> tuple[np.ndarray, ...]:
    """:func:`~slamarena.estimators.stepping.twist_pieces` of every interval ``(key_t[s], key_t[s + 1]]`` of the sorted
    times ``key_t`` at once: the pieces ``(v, ω, dt)`` in time order and the interval ``s`` of each (non-decreasing);
    the same pieces, computed by the same operations, as one call per interval."""
    a, b = key_t[:-1], key_t[1:]
    starts, ends = twist.t, twist.t + twist.dt
    first = np.maximum(np.searchsorted(starts, a, side="right") - 1, 0)
    last = np.searchsorted(starts, b, side="left")
    count = np.maximum(np.where(b > a, last - first, 0), 0)
    interval = np.repeat(np.arange(a.size), count)
    k = np.arange(interval.size) - np.repeat(np.cumsum(count) - count, count) + first[interval]
    lo = np.maximum(starts[k], a[interval])
    hi = np.minimum(ends[k], b[interval])
    keep = hi > lo
    k, interval = k[keep], interval[keep]
    return twist.v[k], twist.omega[k], hi[keep] - lo[keep], interval


def motion_chain(
    sequence: Sequence,
    stamps: np.ndarray,
    params: PoseChainParams,
    *,
    max_interval: float | None = None,
    increment_cov=None,
) -> MotionChain:
    """Pose keys at the start and end of the motion, at ``stamps`` inside it and every ``max_interval`` [s]
    (None: no extra keys); the relative motion between consecutive keys and its covariance (the filters'
    propagation).

    ``params.twist_cov`` / ``increment_cov`` (3, 3) override the sequence's stated motion noise.
    """
    motion = sequence.motion
    if motion is None or not len(motion):
        raise ValueError(f"{sequence.name}: the smoother needs a motion input (Twist or Increments)")
    counts: dict = {}
    if isinstance(motion, Twist):
        M = check_covariance(
            "twist_cov", noise_in_force(params.twist_cov, sequence, "twist_cov", required=True), (2, 2)
        )
        finite = summable(motion.v, motion.omega)
        counts["rejected_nonfinite_motion"] = int((~finite).sum())
        motion = motion.select(finite)
        n_left = len(motion)
    else:
        finite = summable(motion.delta)
        counts["rejected_nonfinite_motion"] = int((~finite).sum())
        if increment_cov is None and motion.cov is not None:
            inc_cov = motion.cov  # the stream's own, row by row: a bad row is rejected below
        else:
            C = noise_in_force(increment_cov, sequence, "increment_cov", required=True)
            inc_cov = np.broadcast_to(check_covariance("increment_cov", C, (3, 3)), (len(motion), 3, 3))
        valid = finite & valid_covariances(inc_cov)
        counts["rejected_invalid_cov_motion"] = int((finite & ~valid).sum())
        inc_cov, inc_delta, inc_t = inc_cov[valid], motion.delta[valid], motion.t[valid]
        n_left = inc_t.size
    if not n_left:
        raise ValueError(f"{sequence.name}: every motion row is rejected ({counts})")

    t_start, t_end = _motion_span(motion)
    stamps = np.asarray(stamps, dtype=float)
    parts = [
        np.array([t_start, t_end]),
        np.where(np.abs(stamps - t_end) <= _STAMP_TOL * max(1.0, abs(t_end)), t_end, stamps),
    ]
    if max_interval is not None:
        parts.append(np.arange(t_start, t_end, max_interval))
    key_t = np.unique(np.concatenate(parts))
    key_t = key_t[(key_t >= t_start) & (key_t <= t_end)]

    S = key_t.size - 1  # intervals between consecutive keys
    if isinstance(motion, Twist):
        v, w, dt, interval = twist_pieces_of_intervals(motion, key_t)
        deltas, P = twist_relatives(MOTION_MODELS[params.motion_model], v, w, dt, interval, S, M)
        moved = np.zeros(S, dtype=bool)
        moved[interval] = True
        deltas, P = deltas[moved], P[moved]
    else:
        moved, deltas, P = np.zeros(S, dtype=bool), [], []
        for s, (a, b) in enumerate(zip(key_t[:-1], key_t[1:])):
            rows = np.flatnonzero((inc_t > a) & (inc_t <= b))
            if rows.size:
                moved[s] = True
                d, C = increments_relative(inc_delta[rows], inc_cov[rows])
                deltas.append(d)
                P.append(C)
    deltas = np.asarray(deltas, dtype=float).reshape(-1, 3)
    cov = regularise(world_to_body(deltas[:, 2], np.asarray(P, dtype=float).reshape(-1, 3, 3)), params.regularisation)
    times = np.concatenate([key_t[:1], key_t[1:][moved]])
    pose_of_stamp = np.concatenate([[0], np.cumsum(moved)])  # an interval without motion keeps the previous key
    singular = np.flatnonzero(np.linalg.eigvalsh(cov)[:, 0] <= 0)
    if singular.size:  # a Gaussian factor needs a positive-definite covariance (GTSAM's error would be NaN)
        k = int(singular[0])
        raise ValueError(
            f"{sequence.name}: the motion from {times[k]:.6g} s to {times[k + 1]:.6g} s (and {singular.size - 1} more) has a "
            f"singular covariance; regularisation = {params.regularisation:g} does not lift it, a value > 0 does"
        )
    return MotionChain(
        t=times,
        start=np.asarray(sequence.start_pose, dtype=float),
        delta=deltas,
        cov=cov,
        stamps=key_t,
        pose_of_stamp=pose_of_stamp,
        counts=counts,
    )


def build_problem(sequence: Sequence, params: LandmarkProblemParams = LandmarkProblemParams()) -> LandmarkProblem:
    """Pose keys, relative motions with their covariances, known-id observations and beacon ranges.

    ``twist_cov``, ``increment_cov``, ``range_bearing_cov`` override the sequence's stated noise;
    beacon ranges have variance ``beacon_range_var`` [m²] and offset ``beacon_bias`` [m] (no
    dataset states them).
    """
    counts: dict = {}
    rb = sequence.range_bearing
    R = noise_in_force(params.range_bearing_cov, sequence, "range_bearing_cov", required=rb is not None and len(rb) > 0)
    if rb is not None and len(rb):
        R = check_covariance("range_bearing_cov", R, (2, 2))
        finite = summable(rb.range, rb.bearing)
        positive = finite & (rb.range >= 0)
        known = rb.landmark_id >= 0
        counts["rejected_nonfinite_observations"] = int((~finite).sum())
        counts["rejected_negative_range_observations"] = int((finite & ~positive).sum())
        counts["skipped_unknown_id_observations"] = int((positive & ~known).sum())
        rb = rb.select(positive & known)
    else:
        R = np.eye(2) if R is None else check_covariance("range_bearing_cov", R, (2, 2))
        rb = None
    br = sequence.beacon_ranges
    if br is not None and len(br):
        finite = summable(br.range)
        positive = finite & (br.range >= 0)
        counts["rejected_nonfinite_ranges"] = int((~finite).sum())
        counts["rejected_negative_ranges"] = int((finite & ~positive).sum())
        br = br.select(positive)
    else:
        br = None
    stamps = np.concatenate([np.zeros(0) if rb is None else rb.t, np.zeros(0) if br is None else br.t])
    chain = motion_chain(sequence, stamps, params, max_interval=params.max_interval, increment_cov=params.increment_cov)
    counts.update(chain.counts)
    if rb is not None:
        rb_t, inside = chain.inside(rb.t)
        counts["skipped_observations_outside_motion"] = int((~inside).sum())
        obs_pose = chain.index(rb_t[inside])
        order = np.argsort(obs_pose, kind="stable")
        obs = (obs_pose[order], rb.landmark_id[inside][order], rb.range[inside][order], rb.bearing[inside][order])
    else:
        obs = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    ranges: dict = {}
    if br is not None:
        br_t, inside = chain.inside(br.t)
        counts["skipped_ranges_outside_motion"] = int((~inside).sum())
        rng_pose = chain.index(br_t[inside])
        order = np.argsort(rng_pose, kind="stable")
        ranges = dict(
            rng_pose=rng_pose[order],
            rng_id=br.beacon_id[inside][order],
            rng_range=br.range[inside][order] - params.beacon_bias,
            R_range=params.beacon_range_var,
        )
    lm = sequence.landmarks
    if lm is not None:
        ranges.update(map_ids=lm.ids, map_xy=lm.xy)
    return LandmarkProblem(
        t=chain.t,
        start=chain.start,
        delta=chain.delta,
        cov=chain.cov,
        obs_pose=obs[0],
        obs_id=obs[1],
        obs_range=obs[2],
        obs_bearing=obs[3],
        R=R,
        obs_cov=observation_covariances(R, obs[2], params.range_bearing_noise),
        counts=counts,
        **ranges,
    )
