"""UTIAS MRCLAM (Leung et al., IJRR 2011): one :class:`Sequence` per robot.

A dataset directory holds ``Barcodes.dat``, ``Landmark_Groundtruth.dat`` and per robot ``k``
``Robot<k>_Odometry.dat``, ``Robot<k>_Measurement.dat`` and (where recorded)
``Robot<k>_Groundtruth.dat``; each may be gzip-compressed (``.dat.gz``). All files have ``#``
header lines and whitespace-separated numeric columns; times are UNIX seconds on one clock.
Any directory in this layout is read as ``utias:<directory>/robot<k>`` (:class:`MrclamSource`;
Datasets 1 and 6 are catalogued as ``utias:1/robot<k>``, ``utias:6/robot<k>``).

- Odometry ``t v ω`` → :class:`Twist` (each command holds until the next stamp;
  :meth:`Twist.from_stamps`, which drops zero-length commands at repeated stamps: counted).
- Measurements ``t barcode range bearing``: the second column is a BARCODE, mapped to a subject
  through ``Barcodes.dat``. Subjects 6–20 are landmarks (kept, ``landmark_id = subject``);
  subjects 1–5 are the other robots (dropped, counted in ``meta["dropped_robot_observations"]``);
  barcodes absent from ``Barcodes.dat`` are misreads (dropped, counted in
  ``meta["dropped_misread_barcodes"]``, values listed in ``meta["misread_barcodes"]``).
- Values outside their physical range (:data:`SPEED`, :data:`TURN_RATE`, :data:`RANGE`, :data:`BEARING`: an
  odometry v of 1e300 m/s, a negative range) are dropped, their lines listed in
  ``meta["dropped_lines"]["out_of_range"]`` per file (a dropped command: the one before holds until the next stamp).
  Subjects and barcodes must be non-negative integers (a barcode 14.5 is not 14, another robot's), barcodes and
  landmark subjects unique: else :class:`DataFormatError` at the line.
- Ground truth (Vicon) ``t x y θ`` → :class:`Trajectory`; landmarks with their survey std-devs.

The dataset states no sensor noise, so :class:`Noise` is left empty (``meta["noise"]`` says so).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import ClassVar

import numpy as np
from pydantic import PositiveInt

from slamarena.params import Field, with_params

from ..geometry import interpolate_poses
from ..sequence import LandmarkMap, Noise, RangeBearing, Sequence, Trajectory, Twist
from ..source import Layout, SourceParams, joined
from ._physical import Bound, dropped_lines, outside
from ._text import check_monotonic, check_unique, integer_ids, numeric_table

__all__ = ["read_table", "read_robot", "read", "MrclamSource", "ROBOT_SUBJECTS"]

#: subjects 1..5 are the robots; 6..20 the landmarks
ROBOT_SUBJECTS = range(1, 6)

#: physical ranges (research/method/data-validation.md): a row with a value outside is dropped (``out_of_range``).
#: The robots are iRobot Creates (top speed 0.5 m/s, so |ω| ≤ 2 · 0.5 / 0.26 m ≈ 3.8 rad/s) in a 15 m × 8 m arena
#: (diagonal 17 m); the limits are 10 × those.
SPEED = Bound(-5.0, 5.0, "m/s", "odometry v: 10 × the iRobot Create's top speed 0.5 m/s (staged: 0 … 0.086 m/s)")
TURN_RATE = Bound(-38.0, 38.0, "rad/s", "odometry ω: 10 × the Create's 3.8 rad/s (staged: |ω| ≤ 0.57 rad/s)")
RANGE = Bound(0.0, 170.0, "m", "a camera range: 10 × the arena's diagonal 17 m (staged: 1.0 … 9.2 m)")
BEARING = Bound(-np.pi, np.pi, "rad", "a bearing is an angle in [−π, π] (staged: |b| ≤ 0.58 rad, the camera's field)")


def read_table(path: str | Path, ncols: int, what: str) -> tuple[np.ndarray, np.ndarray]:
    """All data rows of one MRCLAM file as an ``(N, ncols)`` array and their line numbers."""
    return numeric_table(path, ncols, what)


def read_robot(
    odometry: str | Path,
    measurement: str | Path,
    barcodes: str | Path,
    landmarks: str | Path,
    groundtruth: str | Path | None = None,
    name: str = "mrclam",
) -> Sequence:
    """One robot's run from its files (see the module docstring)."""
    odo, odo_lines = read_table(odometry, 3, "an odometry row (t v omega)")
    check_monotonic(str(odometry), odo[:, 0], odo_lines, "odometry")
    meas, meas_lines = read_table(measurement, 4, "a measurement row (t barcode range bearing)")
    check_monotonic(str(measurement), meas[:, 0], meas_lines, "measurements")
    codes, code_lines = read_table(barcodes, 2, "a barcode row (subject barcode)")
    lm, lm_lines = read_table(landmarks, 5, "a landmark row (subject x y x_std y_std)")
    n_odo, n_meas = len(odo), len(meas)

    absurd, why = outside({"v": (odo[:, 1], SPEED), "omega": (odo[:, 2], TURN_RATE)})
    dropped_odometry = dropped_lines(str(odometry), odo_lines[absurd], why)
    odo = odo[~absurd]
    absurd, why = outside({"range": (meas[:, 2], RANGE), "bearing": (meas[:, 3], BEARING)})
    dropped_measurements = dropped_lines(str(measurement), meas_lines[absurd], why)
    meas, meas_lines = meas[~absurd], meas_lines[~absurd]

    code = integer_ids(barcodes, codes, code_lines, "subject and barcode")
    check_unique(str(barcodes), code[:, 1], code_lines, "barcode")
    subject_of = dict(zip(code[:, 1].tolist(), code[:, 0].tolist()))
    lm_ids = integer_ids(landmarks, lm[:, 0], lm_lines, "subject")
    check_unique(str(landmarks), lm_ids, lm_lines, "landmark subject")
    barcode = integer_ids(measurement, meas[:, 1], meas_lines, "barcode")
    known = np.array(sorted(subject_of), dtype=np.int64)
    subjects = np.array([subject_of[b] for b in known], dtype=np.int64)
    pos = np.clip(np.searchsorted(known, barcode), 0, known.size - 1)
    is_known = known[pos] == barcode
    subject = np.where(is_known, subjects[pos], -1)
    is_robot = np.isin(subject, np.asarray(ROBOT_SUBJECTS))
    keep = is_known & ~is_robot

    motion = Twist.from_stamps(odo[:, 0], odo[:, 1], odo[:, 2])
    rb = RangeBearing(t=meas[keep, 0], range=meas[keep, 2], bearing=meas[keep, 3], landmark_id=subject[keep])
    lmap = LandmarkMap(ids=lm_ids, xy=lm[:, 1:3], std=lm[:, 3:5])

    truth = None
    initial = None
    if groundtruth is not None:
        gt, gt_lines = read_table(groundtruth, 4, "a ground-truth row (t x y theta)")
        check_monotonic(str(groundtruth), gt[:, 0], gt_lines, "ground truth")
        truth = Trajectory(t=gt[:, 0], poses=gt[:, 1:4])
        t_start = motion.t[0]
        if truth.t[0] <= t_start <= truth.t[-1]:
            initial = interpolate_poses(truth.t, truth.poses, np.array([t_start]))[0]

    misreads = np.unique(barcode[~is_known])
    meta = {
        "dataset": "UTIAS MRCLAM",
        "files": [str(p) for p in (odometry, measurement, barcodes, landmarks, groundtruth) if p is not None],
        "odometry_rows": n_odo,
        "odometry_zero_length_commands": int(len(odo) - len(motion)),
        "measurement_rows": n_meas,
        "landmark_observations": int(keep.sum()),
        "dropped_robot_observations": int((is_known & is_robot).sum()),
        "dropped_misread_barcodes": int((~is_known).sum()),
        "misread_barcodes": misreads.tolist(),
        "dropped_lines": {"out_of_range": {"odometry": dropped_odometry, "measurement": dropped_measurements}},
        "ground_truth_kind": "Vicon motion capture" if truth is not None else "none (robot poses not recorded)",
        "initial_pose": "ground truth interpolated at the first odometry stamp" if initial is not None else "not known",
        "noise": "not stated by the dataset",
        "time": "UNIX seconds",
    }
    return Sequence(
        name=name,
        motion=motion,
        range_bearing=rb,
        ground_truth=truth,
        landmarks=lmap,
        initial_pose=initial,
        noise=Noise(),
        meta=meta,
    )


class MrclamSource(SourceParams):
    """Where one robot's MRCLAM files are; the reader has no options."""

    location: ClassVar[tuple[str, ...]] = ("path", "robot")
    form: ClassVar[str] = "<path>/robot<k>"
    path: str = Field(
        description="a directory in the MRCLAM layout: Barcodes.dat, Landmark_Groundtruth.dat, Robot<k>_Odometry.dat, "
        "Robot<k>_Measurement.dat and, where recorded, Robot<k>_Groundtruth.dat (each plain or .gz)"
    )
    robot: PositiveInt = Field(description="k, the robot whose Robot<k>_*.dat files are read")

    @classmethod
    def shorthand(cls, text: str) -> dict:
        match = re.fullmatch(r"(.+)/robot(\d+)", text)
        if match is None:
            raise ValueError(f"expected utias:{cls.form}")
        return {"path": match[1], "robot": int(match[2])}

    def spelled(self) -> str:
        return f"{self.path}/robot{self.robot}"

    def layout(self) -> Layout:
        def dat(stem: str) -> tuple[str, str]:
            return joined(self.path, f"{stem}.dat"), joined(self.path, f"{stem}.dat.gz")

        k = self.robot
        return Layout(
            {
                "odometry": dat(f"Robot{k}_Odometry"),
                "measurement": dat(f"Robot{k}_Measurement"),
                "barcodes": dat("Barcodes"),
                "landmarks": dat("Landmark_Groundtruth"),
                "groundtruth": dat(f"Robot{k}_Groundtruth"),
            },
            frozenset({"groundtruth"}),
        )


@with_params(MrclamSource)
def read(files: dict, name: str, /, *, params: MrclamSource) -> Sequence:
    """The family reader: ``files`` has roles odometry, measurement, barcodes, landmarks[, groundtruth]."""
    return read_robot(name=name, **files)
