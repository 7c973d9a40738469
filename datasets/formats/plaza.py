"""CMU Plaza range-only datasets (Djugash et al., ICRA 2006; the copies shipped with GTSAM).

A run ``PlazaN`` has three files:

``PlazaN_DR.txt``  ``t  Δd  Δθ`` (tab-separated) — odometry: distance travelled and heading change
                   from the previous stamp to ``t``. Integrated as "move Δd along the old heading,
                   then turn Δθ", i.e. the body-frame increment ``(Δd, 0, Δθ)`` of :class:`Increments`
                   (x ⊕ (Δd, 0, Δθ)); this reproduces the ground-truth path of Plaza1 to 1.6 m mean
                   over 1.86 km.
``PlazaN_TD.txt``  ``t  robot_id  beacon_id  range`` — radio ranges [m] to four fixed beacons
                   → :class:`BeaconRanges`.
``PlazaN_.mat``    MATLAB v5 (read by ``scipy.io.loadmat``, :func:`read_mat`): ``GT`` ``(t, x, y, θ)`` ground-truth
                   poses, ``TL`` ``(beacon_id, x, y)`` true beacon positions; also ``DR``/``TD`` (the same
                   numbers as the text files) and ``DRp`` (GTSAM's dead-reckoned path).

What the reader does about the files' quirks (each counted in ``meta``):

- **Out-of-order ranges.** Plaza1_TD.txt jumps back in time twice (lines 1989 and 2867, by 64 s
  and 50 s): two stretches of 120 and 97 measurements were logged after later ones. They agree
  with the ground truth as well as their neighbours do, so they are genuine: the rows are
  sorted by time (stable) and ``meta["range_rows_out_of_order"]`` counts the rows that came
  after a later stamp. ``strict_time=True`` raises :class:`DataFormatError` at the first one.
- **Ground-truth heading of Plaza2 points backwards.** In Plaza2 the robot moves along
  θ_GT + π (99.8 % of moving steps), while every odometry distance is positive; GTSAM's own
  ``DRp`` starts at θ_GT + π. The reader measures this per run — the median angle between
  the ground-truth heading and the direction of travel — and, when it is near π, rotates the
  ground-truth headings by π (``meta["ground_truth_heading"]`` says whether it did and why;
  ``align_heading=False`` keeps the file's values).
- **Values outside their physical range** (:data:`RANGE`, :data:`STEP`, :data:`TURN`; a negative or 1e300 m range,
  a 1e300 m odometry step) are dropped, their lines listed in ``meta["dropped_lines"]["out_of_range"]`` per file
  (a dropped odometry row's motion is lost: the increment cannot be trusted in part).
- The odometry of Plaza1 is unusually good: its Δθ equal the ground-truth heading changes
  exactly (correlation 1.0), so its heading is not independent of the ground truth.
- The ranges carry a bias: measured minus true distance has median +2.8 m (both runs, every
  beacon) and a spread of ≈ 1.1–1.6 m. The files state no noise, so :class:`Noise` stays empty;
  the numbers are in research/method/readers.md.

``initial_pose`` is the first ground-truth pose (at the stamp before the first odometry row:
``GT[k+1].t == DR[k].t`` exactly); ``landmarks`` holds the beacons under their ids.

Catalogued: ``plaza:Plaza1``, ``plaza:Plaza2``; any run in this layout: ``plaza:<dir>/<run>`` (its path
without the suffixes, :class:`PlazaSource`; the ``.mat`` file is optional there).
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np

from slamarena.params import Field, Params, with_params

from ..errors import DataFormatError
from ..geometry import wrap_angle
from ..sequence import BeaconRanges, Increments, LandmarkMap, Noise, Sequence, Trajectory
from ..source import Layout, SourceParams
from ._physical import Bound, dropped_lines, outside
from ._text import check_monotonic, integer_ids, numeric_table

__all__ = ["read_run", "read", "read_mat", "PlazaParams", "PlazaSource", "heading_offset"]

#: a ground-truth step shorter than this [m] says nothing about the direction of travel
_MOVING = 0.05

#: physical ranges (research/method/data-validation.md): a row with a value outside is dropped (``out_of_range``)
RANGE = Bound(
    0.0, 1000.0, "m", "a radio range: the beacons are ≤ 89 m away in both runs; 1 km is beyond the radios' reach"
)
STEP = Bound(
    -10.0, 10.0, "m", "Δd of one odometry row (rows ≈ 0.2 s apart, ≤ 1.24 m in both runs): a 10 m step is 50 m/s"
)
TURN = Bound(-np.pi, np.pi, "rad", "Δθ of one odometry row (≤ 0.15 rad in both runs): more than half a turn in one row")


def read_mat(path: str | Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The numeric matrices ``names`` of a MATLAB v5 MAT-file (``scipy.io.loadmat``).

    A file scipy cannot read (not a MAT-file, truncated, the HDF5-based v7.3 format), a missing variable
    or one that is not a real numeric matrix raises :class:`DataFormatError` naming the file."""
    from scipy.io import loadmat

    path = Path(path)
    try:
        data = loadmat(path, variable_names=list(names))
    except FileNotFoundError:
        raise
    except Exception as exc:  # scipy's reader raises many kinds on damaged input; all mean "not a readable MAT-file"
        raise DataFormatError(path, None, "a MATLAB v5 MAT-file", f"{type(exc).__name__}: {exc}") from None
    out = {}
    for name in names:
        if name not in data:
            raise DataFormatError(path, None, f"a variable {name!r}", "no such variable")
        value = data[name]
        if not (
            isinstance(value, np.ndarray)
            and (np.issubdtype(value.dtype, np.number) or value.dtype == bool)
            and not np.iscomplexobj(value)
        ):
            raise DataFormatError(
                path,
                None,
                f"a real numeric matrix for variable {name!r}",
                type(value).__name__ if not isinstance(value, np.ndarray) else str(value.dtype),
            )
        out[name] = value.astype(float)
    return out


def heading_offset(poses: np.ndarray) -> tuple[float, float]:
    """Median angle from the heading to the direction of travel over moving steps, and the
    fraction of those steps within 0.5 rad of that median."""
    step = np.diff(poses[:, :2], axis=0)
    moving = np.hypot(step[:, 0], step[:, 1]) > _MOVING
    if not moving.any():
        return 0.0, 1.0
    angle = wrap_angle(np.arctan2(step[moving, 1], step[moving, 0]) - poses[:-1, 2][moving])
    median = float(np.angle(np.median(np.cos(angle)) + 1j * np.median(np.sin(angle))))
    return median, float(np.mean(np.abs(wrap_angle(angle - median)) < 0.5))


def _ranges(path: Path, strict_time: bool) -> tuple[BeaconRanges, dict, list[int]]:
    """The range rows (sorted by time), their counts for meta, and the lines dropped out of range."""
    rows, lines = numeric_table(path, 4, "a range row (t robot_id beacon_id range)")
    n_rows = len(rows)
    absurd, why = outside({"range": (rows[:, 3], RANGE)})
    dropped = dropped_lines(str(path), lines[absurd], why)
    rows, lines = rows[~absurd], lines[~absurd]
    t = rows[:, 0]
    if strict_time:
        check_monotonic(str(path), t, lines, "range measurements")
    late = t < np.maximum.accumulate(t)
    order = np.argsort(t, kind="stable")
    ids = integer_ids(path, rows[:, 2], lines, "beacon ids")
    stream = BeaconRanges(t=t[order], range=rows[order, 3], beacon_id=ids[order])
    meta = {
        "range_rows": n_rows,
        "range_rows_out_of_order": int(late.sum()),
        "robot_ids": np.unique(rows[:, 1]).astype(int).tolist(),
    }
    return stream, meta, dropped


class PlazaParams(Params):
    """Options of the Plaza reader (:func:`read_run`, :func:`read`)."""

    strict_time: bool = Field(
        False, description="raise at the first range row stepping back in time instead of sorting the rows"
    )
    align_heading: bool = Field(
        True, description="rotate the ground-truth headings by π when they point against the direction of travel"
    )


@with_params(PlazaParams)
def read_run(
    odometry: str | Path,
    ranges: str | Path,
    truth: str | Path | None = None,
    name: str = "plaza",
    /,
    *,
    params: PlazaParams,
) -> Sequence:
    """One Plaza run from its files (see the module docstring); ``truth`` is the ``.mat`` file."""
    odo, odo_lines = numeric_table(odometry, 3, "an odometry row (t delta_distance delta_heading)")
    check_monotonic(str(odometry), odo[:, 0], odo_lines, "odometry")
    absurd, why = outside({"delta_distance": (odo[:, 1], STEP), "delta_heading": (odo[:, 2], TURN)})
    dropped = dropped_lines(str(odometry), odo_lines[absurd], why)
    odo = odo[~absurd]
    delta = np.column_stack([odo[:, 1], np.zeros(len(odo)), odo[:, 2]])
    beacon_ranges, meta, dropped_ranges = _ranges(Path(ranges), params.strict_time)
    meta = {
        "dataset": "CMU Plaza (range-only)",
        "files": [str(p) for p in (odometry, ranges, truth) if p is not None],
        "odometry_rows": int(len(odo)),
        **meta,
        "dropped_lines": {"out_of_range": {"odometry": dropped, "ranges": dropped_ranges}},
        "noise": "not stated by the dataset",
        "time": "seconds (dataset clock)",
    }

    ground_truth = landmarks = initial = None
    if truth is not None:
        mat = read_mat(truth, ("GT", "TL"))
        gt, tl = mat["GT"], mat["TL"]
        if gt.ndim != 2 or gt.shape[1] != 4 or tl.ndim != 2 or tl.shape[1] != 3:
            raise DataFormatError(truth, None, "GT (N, 4) and TL (L, 3)", f"GT {gt.shape}, TL {tl.shape}")
        check_monotonic(str(truth), gt[:, 0], np.arange(1, len(gt) + 1), "GT rows")
        poses = gt[:, 1:4].copy()
        offset, agreement = heading_offset(poses)
        flip = params.align_heading and abs(offset) > np.pi / 2
        if flip:
            poses[:, 2] = wrap_angle(poses[:, 2] + np.pi)
        meta["ground_truth_heading"] = {
            "travel_minus_heading_median_rad": offset,
            "steps_agreeing": agreement,
            "rotated_by_pi": bool(flip),
            "note": "GT heading points against the direction of travel; rotated by pi"
            if flip
            else "GT heading as in the file",
        }
        ground_truth = Trajectory(t=gt[:, 0], poses=poses)
        landmarks = LandmarkMap(ids=tl[:, 0].astype(np.int64), xy=tl[:, 1:3])
        initial = ground_truth.poses[0]
        meta["ground_truth_kind"] = "GPS-based reference of the authors (poses) + surveyed beacons"
        unknown = np.setdiff1d(np.unique(beacon_ranges.beacon_id), landmarks.ids)
        meta["ranges_to_unknown_beacons"] = int(np.isin(beacon_ranges.beacon_id, unknown).sum())
    return Sequence(
        name=name,
        motion=Increments(t=odo[:, 0], delta=delta),
        beacon_ranges=beacon_ranges,
        ground_truth=ground_truth,
        landmarks=landmarks,
        initial_pose=initial,
        noise=Noise(),
        meta=meta,
    )


class PlazaSource(PlazaParams, SourceParams):
    """Where a Plaza run's files are, and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path",)
    path: str = Field(
        description="a run's path without its suffixes: <dir>/PlazaN names PlazaN_DR.txt (odometry), PlazaN_TD.txt "
        "(ranges) and, where there is one, PlazaN_.mat (ground truth and beacons)"
    )

    def layout(self) -> Layout:
        return Layout(
            {"odometry": (f"{self.path}_DR.txt",), "ranges": (f"{self.path}_TD.txt",), "truth": (f"{self.path}_.mat",)},
            frozenset({"truth"}),
        )


@with_params(PlazaSource)
def read(files: dict, name: str, /, *, params: PlazaSource) -> Sequence:
    """The family reader: ``files`` has roles odometry, ranges and (optional) truth."""
    return read_run(files["odometry"], files["ranges"], files.get("truth"), name, params=params.options(PlazaParams))
