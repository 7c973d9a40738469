"""The ACFR Car Park (Guivant & Nebot): a utility vehicle's speed and steering, raw laser with intensity, GPS, 15
surveyed beacons (``acfr_carpark/SOURCE.md``).

Two MATLAB v5 files in one directory (:func:`~slamarena.datasets.formats.plaza.read_mat`):

``data_set.mat``   ``Velocity``, ``Steering``, ``Time_VS`` (1 × N, 40 Hz): the left rear wheel's speed [m/s], the
                   steering angle [rad], stamps [s]; ``Laser``, ``Intensity`` (S × 361) and ``TimeLaser`` (1 × S):
                   scans of 361 beams over 180° at 0.5° [m], the SICK's reflectivity code per beam, stamps [s];
                   ``GPSLon``, ``GPSLat``, ``TimeGPS`` (1 × G): GPS east and north in local metres, 5 Hz.
``beac_juan3.mat`` ``estbeac`` (15 × 2): the beacons' surveyed (east, north) [m].

As a :class:`Sequence` (the robot frame is the **rear axle centre**, x forward, y left):

* ``motion``: :class:`Twist` of the axle, ``(v, ω)`` from (speed, steering) by the Ackerman model
  (:func:`~slamarena.datasets.kinematics.ackerman_twist`; wheel base L = 2.83 m, encoder wheel h = 0.76 m left of the
  centre line), each row held until the next stamp;
* ``scans``: beam i at ``−π/2 + i · 0.5°`` (beam 0 to the right, counter-clockwise), readings ≥ ``max_range`` = 80 m
  are no return (the file's codes are 81.87–81.91 m; no real return beyond 47 m); intensities are the reflectivity
  level 0–4 (the file's values are multiples of 8192: 0, 8192, …, 32768); ``mount = (3.78, 0.50, mount_heading)``
  (a = 3.78 m ahead of the rear axle, b = 0.50 m left, SOURCE.md); stamps shifted by ``laser_time_offset``;
* ``ground_truth``: the GPS antenna sits at the laser (established from the data, research/method/carpark.md), so the
  axle pose at a GPS stamp is ``p_axle = p_gps − R(φ) (a, b)`` with the heading φ from the GPS track: the laser
  point moves along ``track = φ + atan2(a tan α, L − b tan α)`` (α the steering angle at the stamp), so
  ``φ = track − atan2(a tan α, L − b tan α)``. The track is the central difference of the fixes; where the GPS speed
  is below ``min_track_speed`` the heading is interpolated from the moving stamps around it;
* ``landmarks``: the 15 surveyed beacons, ids 0–14 in the file's order; ``initial_pose``: the ground truth at the first
  motion row (the rows before the first GPS fix, 23 ms of them, are dropped and counted).

The defaults of ``mount_heading`` and ``laser_time_offset`` are the values the calibration established
(research/scripts/carpark_calibration.py; research/method/carpark.md: the beacon returns' scatter over the GPS
path, without the survey). ``noise`` is empty: the dataset states none.

Bad input: an unreadable file, a missing variable, arrays of mismatched shapes, or a non-finite or decreasing stamp
raise :class:`DataFormatError` naming the file and the variable with the (1-based) element, as ``<file>:<element>``
for a 1 × N row. Speeds and steering angles outside their physical ranges (:data:`SPEED`, :data:`STEERING`) are
dropped and counted (``meta["dropped_lines"]``, by element).

Catalogued: ``carpark`` (``acfr_carpark``); any directory with the two files: ``carpark:<dir>``.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np

from slamarena.params import Field, Params, with_params

from ..errors import DataFormatError
from ..geometry import interpolate_poses, wrap_angle
from ..kinematics import ackerman_twist
from ..sequence import LandmarkMap, Noise, Scans, Sequence, Trajectory, Twist
from ..source import Layout, SourceParams, joined
from ._physical import Bound, dropped_lines, outside
from .plaza import read_mat

__all__ = ["CarparkParams", "CarparkSource", "read_files", "read", "VEHICLE", "SPEED", "STEERING"]

#: the vehicle (SOURCE.md): wheel base L, encoder offset h, laser a ahead of the rear axle and b to its left [m]
VEHICLE = {"wheelbase": 2.83, "encoder_offset": 0.76, "laser_ahead": 3.78, "laser_left": 0.50}
SPEED = Bound(-5.0, 15.0, "m/s", "the utility vehicle drives ≤ 3.2 m/s in the car park; 15 m/s is beyond it there")
STEERING = Bound(-1.0, 1.0, "rad", "the steering reaches ±0.63 rad in the file; ±57° is beyond the linkage")
#: the SICK's reflectivity code: intensity = level · 8192
_LEVEL = 8192.0
_BEAMS = 361


class CarparkParams(Params):
    """Options of the car park reader (what the calibration established; research/method/carpark.md)."""

    mount_heading: float = Field(
        -0.014, ge=-0.2, le=0.2, description="the laser's yaw in the vehicle frame [rad] (calibrated: −0.0142 ± 0.0007)"
    )
    laser_time_offset: float = Field(
        -0.015, ge=-0.5, le=0.5, description="added to the laser stamps [s] (calibrated: −0.0152 ± 0.0016)"
    )
    min_track_speed: float = Field(
        0.5, gt=0, description="GPS speed below which the track gives no heading (interpolated there) [m/s]"
    )


def _row(path: Path, name: str, value: np.ndarray, size: int | None = None) -> np.ndarray:
    if value.ndim != 2 or value.shape[0] != 1 or (size is not None and value.shape[1] != size):
        want = f"1 × {size}" if size is not None else "1 × N"
        raise DataFormatError(path, None, f"variable {name!r} of shape {want}", f"{value.shape}")
    return value[0]


def _finite(path: Path, name: str, value: np.ndarray) -> None:
    bad = np.flatnonzero(~np.isfinite(value.reshape(value.shape[0], -1)).all(axis=1))
    if bad.size:
        k = int(bad[0])
        raise DataFormatError(path, k + 1, f"finite values in {name!r} (element {k + 1})", str(value[k]))


def _stamps(path: Path, name: str, t: np.ndarray) -> np.ndarray:
    _finite(path, name, t)
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise DataFormatError(path, k + 1, f"non-decreasing {name!r} (element {k + 1})", f"{t[k]!r} after {t[k - 1]!r}")
    return t


def _heading(t: np.ndarray, xy: np.ndarray, steering: np.ndarray, min_speed: float) -> tuple[np.ndarray, np.ndarray]:
    """The vehicle heading at the GPS stamps from the track of the laser point (module docstring), and the mask of the
    stamps where it was measured (the rest interpolated)."""
    L, a, b = VEHICLE["wheelbase"], VEHICLE["laser_ahead"], VEHICLE["laser_left"]
    vx, vy = np.gradient(xy[:, 0], t), np.gradient(xy[:, 1], t)
    moving = np.hypot(vx, vy) >= min_speed
    if moving.sum() < 2:
        raise ValueError("the GPS track never moves: no heading for the ground truth")
    tan = np.tan(steering)
    phi = np.unwrap(np.arctan2(vy, vx)[moving] - np.arctan2(a * tan[moving], L - b * tan[moving]))
    return wrap_angle(np.interp(t, t[moving], phi)), moving


@with_params(CarparkParams)
def read_files(data: str | Path, beacons: str | Path, name: str = "carpark", /, *, params: CarparkParams) -> Sequence:
    """The car park from ``data_set.mat`` and ``beac_juan3.mat`` (module docstring)."""
    data, beacons = Path(data), Path(beacons)
    names = ("Velocity", "Steering", "Time_VS", "Laser", "Intensity", "TimeLaser", "GPSLon", "GPSLat", "TimeGPS")
    m = read_mat(data, names)
    t_vs = _stamps(data, "Time_VS", _row(data, "Time_VS", m["Time_VS"]))
    speed = _row(data, "Velocity", m["Velocity"], t_vs.size)
    steering = _row(data, "Steering", m["Steering"], t_vs.size)
    for key, value in (("Velocity", speed), ("Steering", steering)):
        _finite(data, key, value)
    t_laser = _stamps(data, "TimeLaser", _row(data, "TimeLaser", m["TimeLaser"]))
    ranges, intensity = m["Laser"], m["Intensity"]
    for key, value in (("Laser", ranges), ("Intensity", intensity)):
        if value.shape != (t_laser.size, _BEAMS):
            raise DataFormatError(data, None, f"variable {key!r} of shape ({t_laser.size}, {_BEAMS})", str(value.shape))
    t_gps = _stamps(data, "TimeGPS", _row(data, "TimeGPS", m["TimeGPS"]))
    east, north = (_row(data, key, m[key], t_gps.size) for key in ("GPSLon", "GPSLat"))
    gps = np.column_stack([east, north])
    _finite(data, "GPSLon/GPSLat", gps)
    surveyed = read_mat(beacons, ("estbeac",))["estbeac"]
    if surveyed.ndim != 2 or surveyed.shape[1] != 2:
        raise DataFormatError(beacons, None, "variable 'estbeac' of shape (B, 2)", str(surveyed.shape))
    _finite(beacons, "estbeac", surveyed)

    absurd, why = outside({"Velocity": (speed, SPEED), "Steering": (steering, STEERING)})
    dropped = dropped_lines(str(data), np.flatnonzero(absurd) + 1, why, noun="speed/steering element")
    early = t_vs < t_gps[0]  # before the first GPS fix there is no reference pose to start from
    keep = ~absurd & ~early
    v, w = ackerman_twist(speed[keep], steering[keep], VEHICLE["wheelbase"], VEHICLE["encoder_offset"])
    motion = Twist.from_stamps(t_vs[keep], v, w)

    a, b = VEHICLE["laser_ahead"], VEHICLE["laser_left"]
    angles = -0.5 * np.pi + np.radians(0.5) * np.arange(_BEAMS)
    scans = Scans(
        t=t_laser + params.laser_time_offset,
        ranges=ranges,
        angles=angles,
        max_range=80.0,
        mount=np.array([a, b, params.mount_heading]),
        intensities=intensity / _LEVEL,
    )

    alpha = np.interp(t_gps, t_vs[keep], steering[keep])
    phi, measured = _heading(t_gps, gps, alpha, params.min_track_speed)
    c, s = np.cos(phi), np.sin(phi)
    axle = np.column_stack([east - (c * a - s * b), north - (s * a + c * b), phi])
    truth = Trajectory(t=t_gps, poses=axle)
    start = interpolate_poses(truth.t, truth.poses, motion.t[:1])[0]
    meta = {
        "dataset": "ACFR Car Park (Guivant & Nebot)",
        "files": [str(data), str(beacons)],
        "vehicle": dict(VEHICLE),
        "calibration": params.canonical(),
        "robot_frame": "rear axle centre (x forward, y left); the laser at mount",
        "ground_truth_kind": "GPS (antenna at the laser, moved to the axle by the track heading) + surveyed beacons",
        "ground_truth_heading": f"from the GPS track, {int(measured.sum())} of {measured.size} fixes moving "
        f"(≥ {params.min_track_speed} m/s), the rest interpolated",
        "intensity": "SICK reflectivity level 0-4 (file value / 8192)",
        "dropped_lines": {"out_of_range": {"data_set.mat": dropped}},
        "motion_rows_before_first_fix": int(early.sum()),
        "noise": "not stated by the dataset",
        "time": "seconds (dataset clock)",
    }
    return Sequence(
        name=name,
        motion=motion,
        scans=scans,
        ground_truth=truth,
        landmarks=LandmarkMap(ids=np.arange(len(surveyed)), xy=surveyed),
        initial_pose=start,
        noise=Noise(),
        meta=meta,
    )


class CarparkSource(CarparkParams, SourceParams):
    """Where the car park's two files are, and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path",)
    path: str = Field(description="a directory holding data_set.mat and beac_juan3.mat")

    def layout(self) -> Layout:
        return Layout({"data": (joined(self.path, "data_set.mat"),), "beacons": (joined(self.path, "beac_juan3.mat"),)})


@with_params(CarparkSource)
def read(files: dict, name: str, /, *, params: CarparkSource) -> Sequence:
    """The family reader: roles ``data`` and ``beacons``."""
    return read_files(files["data"], files["beacons"], name, params=params.options(CarparkParams))
