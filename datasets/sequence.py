"""The data model of one robot run: a ``Sequence`` of time-stamped, struct-of-arrays streams.

Every stream is a frozen dataclass of numpy arrays with a leading time axis ``t`` (seconds,
non-decreasing, finite). Validation happens on construction: matching lengths, monotonic
time, finite values where the quantity can never be missing (time, ground truth, poses).
Measurement values may be non-finite: the consumers reject and count them, so a bad
reading is never silently dropped by the data layer.

Streams
-------
``Twist``         motion input as velocities ``(v, omega)`` held for ``dt`` from ``t``.
``Increments``    motion input as body-frame pose increments ``(dx, dy, dtheta)`` from the
                  previous stamp to ``t`` (odometry), optional per-increment covariance.
``RangeBearing``  landmark observations ``(range, bearing, landmark_id)``; ``id = -1`` unknown.
``BeaconRanges``  range-only measurements to radio beacons ``(range, beacon_id)``.
``Gps``           absolute position ``(x, y)``.
``Heading``       absolute yaw (an IMU with magnetometer): ``yaw``.
``Scans``         2D laser scans ``ranges[S, B]`` with beam angles, max range, mounting pose
                  and the pose the log attached to each scan (odometry or corrected);
                  interlaced scanners: per-scan ``angle_offset`` and ``beam_count``.
``Camera``        camera frames (image files read on demand, never all at once), intrinsics ``K``,
                  lens distortion, an optional rectified right image per frame with its baseline,
                  and the camera poses ``T_world←cam`` the dataset gives as ground truth.
``Trajectory``    time-stamped poses ``(x, y, theta)`` (ground truth, reference).
``LandmarkMap``   landmark ids and positions, optional std-devs (ground truth).
``Noise``         the dataset's stated noise, each field optional.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, fields
from typing import NamedTuple

import numpy as np

from .errors import DataFormatError
from .geometry import wrap_angle

__all__ = [
    "Twist",
    "Increments",
    "RangeBearing",
    "BeaconRanges",
    "Gps",
    "Heading",
    "Scans",
    "Camera",
    "Trajectory",
    "LandmarkMap",
    "Noise",
    "Sequence",
    "Event",
    "STREAMS",
]


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _check_time(name: str, t: np.ndarray) -> None:
    if t.ndim != 1:
        raise ValueError(f"{name}.t must be 1-D, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{name}.t has non-finite values")
    if t.size > 1:
        bad = np.flatnonzero(np.diff(t) < 0)
        if bad.size:
            k = int(bad[0])
            raise ValueError(f"{name}.t is not monotonic: t[{k}]={float(t[k])!r} > t[{k + 1}]={float(t[k + 1])!r}")


def _check_len(name: str, t: np.ndarray, **arrays: np.ndarray) -> None:
    for key, a in arrays.items():
        if a.shape[0] != t.shape[0]:
            raise ValueError(f"{name}.{key} has {a.shape[0]} rows but {name}.t has {t.shape[0]}")


def _check_finite(name: str, **arrays: np.ndarray) -> None:
    for key, a in arrays.items():
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}.{key} has non-finite values")


class _Stream:
    """Common behaviour: length, slicing by index, count of non-finite measurement values."""

    t: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def _measurement_arrays(self) -> dict[str, np.ndarray]:
        return {}

    def nonfinite_count(self) -> int:
        """Number of rows with a non-finite measurement value."""
        bad = np.zeros(len(self), dtype=bool)
        for a in self._measurement_arrays().values():
            bad |= ~np.isfinite(a.reshape(len(self), -1)).all(axis=1)
        return int(bad.sum())

    def select(self, index):
        """The stream restricted to rows ``index`` (a slice, mask or integer array)."""
        kwargs = {}
        for f in fields(self):
            value = getattr(self, f.name)
            per_row = (
                isinstance(value, np.ndarray)
                and value.ndim >= 1
                and value.shape[0] == len(self)
                and f.metadata.get("per_row", True)
            )
            kwargs[f.name] = value[index] if per_row else value
        return type(self)(**kwargs)


@dataclass(frozen=True)
class Twist(_Stream):
    """Velocity commands or measured velocities: ``(v, omega)`` held for ``dt`` from ``t``.

    Units: t [s], v [m/s], omega [rad/s], dt [s] (> 0).
    """

    t: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    dt: np.ndarray

    def __post_init__(self):
        for k in ("t", "v", "omega", "dt"):
            object.__setattr__(self, k, _f64(getattr(self, k)))
        _check_time("Twist", self.t)
        _check_len("Twist", self.t, v=self.v, omega=self.omega, dt=self.dt)
        _check_finite("Twist", dt=self.dt)
        if np.any(self.dt <= 0):
            raise ValueError("Twist.dt must be > 0")

    @classmethod
    def from_stamps(cls, t, v, omega, last_dt: float | None = None) -> Twist:
        """Each command holds until the next stamp; the last one for ``last_dt`` (default: median)."""
        t = _f64(t)
        gaps = np.diff(t)
        if last_dt is None:
            positive = gaps[gaps > 0]
            last_dt = float(np.median(positive)) if positive.size else 1.0
        dt = np.append(gaps, last_dt)
        keep = dt > 0
        return cls(t=t[keep], v=_f64(v)[keep], omega=_f64(omega)[keep], dt=dt[keep])

    def _measurement_arrays(self):
        return {"v": self.v, "omega": self.omega}


@dataclass(frozen=True)
class Increments(_Stream):
    """Body-frame odometry increments ``(dx, dy, dtheta)`` from the previous stamp to ``t``.

    ``cov`` (K, 3, 3), when given, is the covariance of each increment.
    """

    t: np.ndarray
    delta: np.ndarray
    cov: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        object.__setattr__(self, "delta", _f64(self.delta).reshape(-1, 3))
        _check_time("Increments", self.t)
        _check_len("Increments", self.t, delta=self.delta)
        if self.cov is not None:
            object.__setattr__(self, "cov", _f64(self.cov).reshape(-1, 3, 3))
            _check_len("Increments", self.t, cov=self.cov)

    def _measurement_arrays(self):
        return {"delta": self.delta}


@dataclass(frozen=True)
class RangeBearing(_Stream):
    """Landmark observations; rows sharing a stamp form one observation set (one ``update(z)``).

    Units: range [m], bearing [rad] relative to the heading (counter-clockwise), id −1 = unknown.
    """

    t: np.ndarray
    range: np.ndarray
    bearing: np.ndarray
    landmark_id: np.ndarray

    def __post_init__(self):
        for k in ("t", "range", "bearing"):
            object.__setattr__(self, k, _f64(getattr(self, k)))
        object.__setattr__(self, "landmark_id", np.ascontiguousarray(self.landmark_id, dtype=np.int64))
        _check_time("RangeBearing", self.t)
        _check_len("RangeBearing", self.t, range=self.range, bearing=self.bearing, landmark_id=self.landmark_id)

    @property
    def z(self) -> np.ndarray:
        """Observations as the ``(M, 3)`` matrix ``[range, bearing, id]`` of the EKF-SLAM notes."""
        return np.column_stack([self.range, self.bearing, self.landmark_id.astype(np.float64)])

    def _measurement_arrays(self):
        return {"range": self.range, "bearing": self.bearing}


@dataclass(frozen=True)
class BeaconRanges(_Stream):
    """Range-only measurements to beacons at known or unknown positions (no bearing).

    Units: range [m] from the sensor to the beacon, beacon_id ≥ 0 (the dataset's beacon
    numbering; true positions, where known, are ``Sequence.landmarks`` under the same ids).
    Rows sharing a stamp form one measurement set.
    """

    t: np.ndarray
    range: np.ndarray
    beacon_id: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        object.__setattr__(self, "range", _f64(self.range))
        object.__setattr__(self, "beacon_id", np.ascontiguousarray(self.beacon_id, dtype=np.int64))
        _check_time("BeaconRanges", self.t)
        _check_len("BeaconRanges", self.t, range=self.range, beacon_id=self.beacon_id)
        if np.any(self.beacon_id < 0):
            raise ValueError("BeaconRanges.beacon_id must be >= 0")

    def _measurement_arrays(self):
        return {"range": self.range}


@dataclass(frozen=True)
class Gps(_Stream):
    """Absolute position fixes ``xy`` (K, 2) in the world frame [m]."""

    t: np.ndarray
    xy: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        object.__setattr__(self, "xy", _f64(self.xy).reshape(-1, 2))
        _check_time("Gps", self.t)
        _check_len("Gps", self.t, xy=self.xy)

    def _measurement_arrays(self):
        return {"xy": self.xy}


@dataclass(frozen=True)
class Heading(_Stream):
    """Absolute yaw [rad] in the world frame (x east, y north, counter-clockwise from east); optionally the
    gyro's yaw rate [rad/s] at the same stamps (an IMU's ``angular_velocity.z``)."""

    t: np.ndarray
    yaw: np.ndarray
    yaw_rate: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        object.__setattr__(self, "yaw", _f64(self.yaw))
        _check_time("Heading", self.t)
        _check_len("Heading", self.t, yaw=self.yaw)
        if self.yaw_rate is not None:
            object.__setattr__(self, "yaw_rate", _f64(self.yaw_rate))
            _check_len("Heading", self.t, yaw_rate=self.yaw_rate)

    def _measurement_arrays(self):
        return {"yaw": self.yaw}


@dataclass(frozen=True)
class Scans(_Stream):
    """2D laser scans.

    ranges (S, B) [m]; angles (B,) beam angles in the sensor frame [rad]; max_range [m]:
    readings ``>= max_range`` are "no return"; mount (3,) sensor pose in the robot frame;
    pose (S, 3) the robot pose the log attached to each scan (odometry, or the corrected
    pose of a corrected log), optional. intensities (S, B), optional: each reading's intensity
    (remission) as the sensor reports it, unitless.

    Interlaced scanners (several beam layouts with one angular step in one stream, e.g.
    fr-clinic's SICK at 1° steps starting at −90°, −89.75°, −89.5°, −89.25°):

    angle_offset (S,) [rad], optional: beam b of scan s points at ``angles[b] + angle_offset[s]``
        (None: 0 for every scan). Finite.
    beam_count (S,) int, optional: scan s has the beams ``0 … beam_count[s] − 1``; the rest
        of its row is padding, not a reading (None: every scan has B beams). Padding is
        stored as NaN (set on construction), so a consumer that ignored ``beam_count`` would
        reject it rather than map it; :meth:`nonfinite_count` (and the summary's data-quality
        numbers) count only real beams.

    Consumers take a scan's beams from :meth:`beams` (``ranges, angles`` of its real beams)
    instead of pairing ``ranges[k]`` with ``angles``; the two agree whenever both optional
    fields are None. Both are per row: :meth:`select` keeps them with their scans.
    """

    t: np.ndarray
    ranges: np.ndarray
    angles: np.ndarray = field(metadata={"per_row": False})
    max_range: float = 80.0
    mount: np.ndarray = field(default_factory=lambda: np.zeros(3), metadata={"per_row": False})
    pose: np.ndarray | None = None
    angle_offset: np.ndarray | None = None
    beam_count: np.ndarray | None = None
    intensities: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        ranges = np.asarray(self.ranges)
        object.__setattr__(
            self, "ranges", np.ascontiguousarray(ranges, dtype=np.float32 if ranges.dtype == np.float32 else np.float64)
        )
        object.__setattr__(self, "angles", _f64(self.angles))
        object.__setattr__(self, "mount", _f64(self.mount).reshape(3))
        object.__setattr__(self, "max_range", float(self.max_range))
        _check_time("Scans", self.t)
        if self.ranges.ndim != 2 or self.ranges.shape[1] != self.angles.shape[0]:
            raise ValueError(f"Scans.ranges must be (S, {self.angles.shape[0]}), got {self.ranges.shape}")
        _check_len("Scans", self.t, ranges=self.ranges)
        _check_finite("Scans", angles=self.angles, mount=self.mount)
        if self.pose is not None:
            object.__setattr__(self, "pose", _f64(self.pose).reshape(-1, 3))
            _check_len("Scans", self.t, pose=self.pose)
        S, B = self.ranges.shape
        if self.intensities is not None:
            intensities = np.ascontiguousarray(self.intensities, dtype=np.float32)
            if intensities.shape != (S, B):
                raise ValueError(f"Scans.intensities must be ({S}, {B}), got {intensities.shape}")
            object.__setattr__(self, "intensities", intensities)
        if self.angle_offset is not None:
            offset = _f64(self.angle_offset)
            if offset.shape != (S,):
                raise ValueError(f"Scans.angle_offset must be ({S},), got {offset.shape}")
            _check_finite("Scans", angle_offset=offset)
            object.__setattr__(self, "angle_offset", offset)
        if self.beam_count is not None:
            count = np.asarray(self.beam_count)
            if count.shape != (S,):
                raise ValueError(f"Scans.beam_count must be ({S},), got {count.shape}")
            if count.size and (
                not np.all(np.isfinite(count)) or np.any(count != np.round(count)) or count.min() < 0 or count.max() > B
            ):
                raise ValueError(f"Scans.beam_count must be integers in [0, {B}]")
            object.__setattr__(self, "beam_count", np.ascontiguousarray(count, dtype=np.int64))
            padding = self._padding()
            if not np.all(np.isnan(self.ranges[padding])):
                object.__setattr__(self, "ranges", np.where(padding, np.nan, self.ranges).astype(self.ranges.dtype))

    def _padding(self) -> np.ndarray:
        """(S, B) True where a row holds padding, not a beam (all False without ``beam_count``)."""
        S, B = self.ranges.shape
        if self.beam_count is None:
            return np.zeros((S, B), dtype=bool)
        return np.arange(B)[None, :] >= self.beam_count[:, None]

    def beams(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Scan ``k``'s real beams: ranges (n,) float64 [m] and their angles (n,) in the sensor frame [rad]."""
        n = self.ranges.shape[1] if self.beam_count is None else int(self.beam_count[k])
        angles = self.angles[:n] if self.angle_offset is None else self.angles[:n] + self.angle_offset[k]
        return self.ranges[k, :n].astype(np.float64), angles

    def nonfinite_count(self) -> int:
        """Number of scans with a non-finite reading among their real beams (padding is not a reading)."""
        return int((~np.isfinite(self.ranges) & ~self._padding()).any(axis=1).sum())

    def _measurement_arrays(self):
        return {"ranges": self.ranges}


@dataclass(frozen=True)
class Camera(_Stream):
    """Camera frames of a pinhole camera, the images read from their files on demand (:meth:`image`).

    t (N,) [s]; left (N,) image file per frame (str); K (3, 3) intrinsics ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``
    [px]; distortion (D,) the coefficients of ``distortion_model`` (empty: none):

    - ``"none"``: an ideal (or rectified) pinhole;
    - ``"radial_pixels"``: ``p_d = c + (p_u − c)(1 + k1 r² + k2 r⁴)``, ``r² = ||p_u − c||²`` in pixels on the
      undistorted image, ``c = (cx, cy)``, D = (k1 [px⁻²], k2 [px⁻⁴]) (the UZH course's model).

    right (N,), optional: the rectified right image of each frame ("" where the dataset has none); its camera is the
    left one translated by ``baseline`` [m] along +x (``P1 = K [I | −(b, 0, 0)ᵀ]``).
    ground_truth (N, 4, 4), optional: the pose ``T_world←cam`` of each frame's (left) camera; camera axes x right,
    y down, z forward. All values finite.
    """

    t: np.ndarray
    left: np.ndarray
    K: np.ndarray = field(metadata={"per_row": False})
    distortion: np.ndarray = field(default_factory=lambda: np.zeros(0), metadata={"per_row": False})
    distortion_model: str = "none"
    width: int = 0
    height: int = 0
    right: np.ndarray | None = None
    baseline: float | None = None
    ground_truth: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        object.__setattr__(self, "left", np.asarray(self.left, dtype=str))
        object.__setattr__(self, "K", _f64(self.K).reshape(3, 3))
        object.__setattr__(self, "distortion", _f64(self.distortion).reshape(-1))
        _check_time("Camera", self.t)
        _check_len("Camera", self.t, left=self.left)
        _check_finite("Camera", K=self.K, distortion=self.distortion)
        if self.distortion_model not in ("none", "radial_pixels"):
            raise ValueError(
                f"Camera.distortion_model must be 'none' or 'radial_pixels', got {self.distortion_model!r}"
            )
        if self.distortion_model == "radial_pixels" and self.distortion.shape != (2,):
            raise ValueError(f"Camera.distortion of the radial_pixels model is (k1, k2), got {self.distortion.shape}")
        if self.right is not None:
            object.__setattr__(self, "right", np.asarray(self.right, dtype=str))
            _check_len("Camera", self.t, right=self.right)
            if self.baseline is None or not np.isfinite(self.baseline) or self.baseline <= 0:
                raise ValueError(f"Camera.right needs a positive finite baseline, got {self.baseline!r}")
        if self.ground_truth is not None:
            object.__setattr__(self, "ground_truth", _f64(self.ground_truth).reshape(-1, 4, 4))
            _check_len("Camera", self.t, ground_truth=self.ground_truth)
            _check_finite("Camera", ground_truth=self.ground_truth)

    @property
    def stereo(self) -> np.ndarray:
        """(N,) bool: the frames that have a right image."""
        return np.zeros(len(self), bool) if self.right is None else self.right != ""

    def image(self, k: int, side: str = "left") -> np.ndarray:
        """Frame ``k``'s image (``side`` left or right) as an (H, W) uint8 grey image, read from its file now."""
        import cv2  # imported on first use: the CLI starts fast

        files = self.left if side == "left" else self.right
        if side not in ("left", "right") or files is None or files[k] == "":
            raise KeyError(f"frame {k} has no {side} image")
        image = cv2.imread(str(files[k]), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise DataFormatError(files[k], None, "an image OpenCV can read", "unreadable or missing")
        return image


@dataclass(frozen=True)
class Trajectory(_Stream):
    """Time-stamped poses (K, 3) ``(x, y, theta)``; all values finite."""

    t: np.ndarray
    poses: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "t", _f64(self.t))
        poses = _f64(self.poses).reshape(-1, 3).copy()
        poses[:, 2] = wrap_angle(poses[:, 2])
        object.__setattr__(self, "poses", poses)
        _check_time("Trajectory", self.t)
        _check_len("Trajectory", self.t, poses=self.poses)
        _check_finite("Trajectory", poses=self.poses)


@dataclass(frozen=True)
class LandmarkMap:
    """Landmark ids (L,), positions (L, 2) and optional position std-devs (L, 2)."""

    ids: np.ndarray
    xy: np.ndarray
    std: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "ids", np.ascontiguousarray(self.ids, dtype=np.int64))
        object.__setattr__(self, "xy", _f64(self.xy).reshape(-1, 2))
        if self.ids.shape[0] != self.xy.shape[0]:
            raise ValueError("LandmarkMap.ids and .xy differ in length")
        if np.unique(self.ids).size != self.ids.size:
            raise ValueError("LandmarkMap.ids are not unique")
        _check_finite("LandmarkMap", xy=self.xy)
        if self.std is not None:
            object.__setattr__(self, "std", _f64(self.std).reshape(-1, 2))

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    def position(self, landmark_id: int) -> np.ndarray:
        k = np.flatnonzero(self.ids == landmark_id)
        if k.size == 0:
            raise KeyError(landmark_id)
        return self.xy[k[0]]


@dataclass(frozen=True)
class Noise:
    """The noise a dataset states for its streams (each optional; standard deviations squared).

    twist_cov (2, 2): covariance of the commanded/measured ``(v, omega)`` [(m/s)², (rad/s)²].
    increment_cov (3, 3): covariance of one odometry increment ``(dx, dy, dtheta)``.
    range_bearing_cov (2, 2): observation noise ``diag(σ_r², σ_b²)``.
    gps_cov (2, 2), yaw_var: absolute sensors.
    """

    twist_cov: np.ndarray | None = None
    increment_cov: np.ndarray | None = None
    range_bearing_cov: np.ndarray | None = None
    gps_cov: np.ndarray | None = None
    yaw_var: float | None = None

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None and f.name != "yaw_var":
                object.__setattr__(self, f.name, _f64(value))


STREAMS = ("motion", "range_bearing", "beacon_ranges", "gps", "heading", "scans", "camera")


class Event(NamedTuple):
    """One step of the time-ordered merge: rows ``start:stop`` of stream ``stream`` at time ``t``."""

    t: float
    stream: str
    start: int
    stop: int


@dataclass(frozen=True)
class Sequence:
    """One run of one robot: optional streams, ground truth and stated noise.

    ``motion`` is a :class:`Twist` or :class:`Increments`. ``ground_truth`` and ``landmarks``
    are the truth where the dataset has it. ``meta`` holds provenance (dataset name,
    files, counts of what the reader dropped, units notes).
    """

    name: str
    motion: Twist | Increments | None = None
    range_bearing: RangeBearing | None = None
    beacon_ranges: BeaconRanges | None = None
    gps: Gps | None = None
    heading: Heading | None = None
    scans: Scans | None = None
    camera: Camera | None = None
    ground_truth: Trajectory | None = None
    landmarks: LandmarkMap | None = None
    initial_pose: np.ndarray | None = None
    noise: Noise = field(default_factory=Noise)
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.motion is not None and not isinstance(self.motion, (Twist, Increments)):
            raise TypeError("Sequence.motion must be Twist or Increments")
        for stream, cls in (
            ("range_bearing", RangeBearing),
            ("beacon_ranges", BeaconRanges),
            ("gps", Gps),
            ("heading", Heading),
            ("scans", Scans),
            ("camera", Camera),
        ):
            value = getattr(self, stream)
            if value is not None and not isinstance(value, cls):
                raise TypeError(f"Sequence.{stream} must be {cls.__name__}")
        if self.initial_pose is not None:
            pose = _f64(self.initial_pose).reshape(3)
            _check_finite("Sequence", initial_pose=pose)
            object.__setattr__(self, "initial_pose", pose)

    # ------------------------------------------------------------------ access
    def streams(self) -> dict[str, _Stream]:
        """The present time-stamped input streams, by name."""
        return {s: getattr(self, s) for s in STREAMS if getattr(self, s) is not None}

    @property
    def start_pose(self) -> np.ndarray:
        """Initial pose: stated, else the ground truth at the start, else the origin."""
        if self.initial_pose is not None:
            return self.initial_pose
        if self.ground_truth is not None and len(self.ground_truth):
            return self.ground_truth.poses[0].copy()
        return np.zeros(3)

    @property
    def t0(self) -> float:
        starts = [s.t[0] for s in self.streams().values() if len(s)]
        return float(min(starts)) if starts else 0.0

    @property
    def t1(self) -> float:
        ends = [s.t[-1] for s in self.streams().values() if len(s)]
        return float(max(ends)) if ends else 0.0

    # ------------------------------------------------------------------ merge
    def event_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The time-ordered merge of all input streams as arrays ``(t, stream_code, start, stop)``.

        ``stream_code`` indexes :data:`STREAMS`. Range-bearing (and beacon-range) rows with one
        stamp are one event. At equal times the order is the order of :data:`STREAMS` (motion first, so a
        filter predicts to the stamp, then applies the measurements), stable within a stream.
        """
        ts, codes, starts, stops = [], [], [], []
        for code, name in enumerate(STREAMS):
            stream = getattr(self, name)
            if stream is None or not len(stream):
                continue
            t = stream.t
            if name in ("range_bearing", "beacon_ranges"):
                first = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
                last = np.r_[first[1:], len(t)]
            else:
                first = np.arange(len(t))
                last = first + 1
            ts.append(t[first])
            codes.append(np.full(first.size, code, dtype=np.int8))
            starts.append(first)
            stops.append(last)
        if not ts:
            empty = np.zeros(0)
            return empty, empty.astype(np.int8), empty.astype(np.int64), empty.astype(np.int64)
        t = np.concatenate(ts)
        code = np.concatenate(codes)
        start = np.concatenate(starts)
        stop = np.concatenate(stops)
        order = np.lexsort((start, code, t))
        return t[order], code[order], start[order], stop[order]

    def events(self) -> Iterator[Event]:
        """Iterate the time-ordered merge of all input streams (see :meth:`event_table`)."""
        t, code, start, stop = self.event_table()
        for k in range(t.size):
            yield Event(float(t[k]), STREAMS[code[k]], int(start[k]), int(stop[k]))

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict:
        """Counts, time span, rates and data-quality numbers, for ``slamarena data info``."""
        out: dict = {"name": self.name, "t0": self.t0, "t1": self.t1, "duration_s": self.t1 - self.t0}
        for name, stream in self.streams().items():
            entry = {"kind": type(stream).__name__, "count": len(stream)}
            if len(stream) > 1:
                span = float(stream.t[-1] - stream.t[0])
                entry["rate_hz"] = (len(stream) - 1) / span if span > 0 else None
            entry["nonfinite_rows"] = stream.nonfinite_count()
            if name == "range_bearing":
                ids = stream.landmark_id
                entry["known_ids"] = int(np.unique(ids[ids >= 0]).size)
                entry["unknown_id_rows"] = int((ids < 0).sum())
                entry["observation_sets"] = int(np.unique(stream.t).size)
            if name == "beacon_ranges":
                entry["beacons"] = int(np.unique(stream.beacon_id).size)
            if name == "scans":
                entry["beams"] = int(stream.ranges.shape[1])
                if stream.angle_offset is not None:
                    entry["interlaced_offsets"] = int(np.unique(stream.angle_offset).size)
                entry["max_range"] = stream.max_range
            if name == "camera":
                entry["image_size"] = [stream.width, stream.height]
                entry["K"] = stream.K.tolist()
                entry["distortion_model"] = stream.distortion_model
                entry["distortion"] = stream.distortion.tolist()
                entry["stereo_frames"] = int(stream.stereo.sum())
                entry["baseline_m"] = stream.baseline
                entry["ground_truth_poses"] = 0 if stream.ground_truth is None else len(stream)
            out[name] = entry
        out["ground_truth"] = (
            None
            if self.ground_truth is None
            else {
                "count": len(self.ground_truth),
                "t0": float(self.ground_truth.t[0]) if len(self.ground_truth) else None,
                "t1": float(self.ground_truth.t[-1]) if len(self.ground_truth) else None,
            }
        )
        out["landmarks"] = None if self.landmarks is None else len(self.landmarks)
        out["noise"] = {
            f.name: (None if getattr(self.noise, f.name) is None else np.asarray(getattr(self.noise, f.name)).tolist())
            for f in fields(self.noise)
        }
        out["meta"] = {
            k: v for k, v in self.meta.items() if isinstance(v, (str, int, float, bool, list, dict, type(None)))
        }
        return out
