"""CARMEN log files (``.clf``, ``.log``; optionally ``.gz``/``.bz2``): raw and SLAM-corrected logs.

One message per line (metres, radians; the last three fields of a message are
``ipc_timestamp ipc_hostname logger_timestamp``)::

    ODOM        x y θ tv rv accel  ts host lts                      odometry pose of the robot
    FLASER      n r_1…r_n  x y θ  odom_x odom_y odom_θ  ts host lts  laser pose, robot odometry pose
    ROBOTLASER1 type start fov res max_range accuracy remission_mode n r_1…r_n  m rem_1…rem_m
                laser_x laser_y laser_θ  robot_x robot_y robot_θ  tv rv fwd_safety side_safety turn_axis ts host lts
    PARAM name value ts host lts        kept in meta["params"]
    NEFF value                          (corrected logs) counted

Other message names (SYNC, RLASER, TRUEPOS, NMEA…) are counted in ``meta["ignored_messages"]``;
a first token that is not a message name (upper-case identifier) is a :class:`DataFormatError`.
A line holding bytes no text has (binary garbage: a message damaged in storage or transfer) is
dropped, whatever it starts with: listed in ``meta["dropped_lines"]["binary_garbage"]`` and
reported by a :class:`~slamarena.datasets.errors.DataWarning` naming the file and line.

The :class:`Sequence` of a **raw** log:

- ``scans``: :class:`Scans` (float32 ranges) with ``pose`` = the robot's odometry pose at each
  scan, ``mount`` = the laser pose in the robot frame (FLASER: ``between(odom pose, laser pose)``;
  ROBOTLASER1: ``between(robot pose, laser pose)``; the median over scans, the spread is in
  ``meta["mount_spread"]``). Beam angles: FLASER covers 180° from −90°, ``n`` even → step π/n
  (180 → 1°, 360 → 0.5°), ``n`` odd → step π/(n−1) (181, 361: both ends included); ROBOTLASER1
  states ``start + k·res``.
  ``max_range``: readings ``>= max_range`` are "no return" (the per-dataset sentinel, e.g. 81.83 m
  for Intel; when not given: ROBOTLASER1's stated max range, else the largest reading of the log).
- Beam layouts (``meta["beam_layouts"]``: beams, start, step, scans, chosen, angle_offset). The
  most common layout is kept together with the layouts that **interlace** with it: the same step,
  a start less than one step away and at most one beam more or fewer (fr-clinic's SICK runs
  interlaced: 1748 scans of 181 beams from −90° and 1709 / 1725 / 1735 scans of 180 beams from
  −89.75° / −89.5° / −89.25°, all at 1° steps). Such a stream (``meta["interlaced"]``) has
  ``angles = base + k·step`` from the smallest start ``base``, B = the largest beam count, and
  per scan ``angle_offset = start − base`` and ``beam_count`` (rows padded with NaN; see
  :class:`Scans`). ``beams=n`` keeps the single most common layout with n beams and
  ``interlaced=False`` the single most common layout (one layout, no offsets). Layouts with
  another step or field of view are never mixed into one stream: their scans are dropped and
  counted (``meta["dropped_scans_other_layout"]``).
- ``motion``: :class:`Increments` ``between(pose_{k−1}, pose_k)`` of consecutive ODOM poses at the
  ODOM stamps (logs without ODOM: of the scans' odometry poses at the scan stamps).
- ``initial_pose``: the first odometry pose, so dead reckoning reproduces the odometry frame.

A **corrected** log (``corrected=True``) carries the SLAM-corrected pose in the FLASER pose fields
and repeats it in an ODOM line with timestamp 0 after each scan; those ODOM lines are skipped
(counted). ``Scans.pose`` and ``ground_truth`` are the corrected poses (with ``odometry_scan_pose``, ``Scans.pose`` is
the raw odometry pose before each scan instead, so that a mapper sees the odometry only)
(``meta["ground_truth_kind"] = "slam-reference"``: a reference, not independent truth); ``motion``
is the raw odometry between consecutive scans (the last raw ODOM pose before each scan).

Time: ``t`` is the ipc_timestamp; the file order is the true order. Per stream (scans; ODOM in a raw
log) the **clock** is the longest subsequence, in file order, of the positive, finite stamps that
never steps back (:func:`clock_faults`). Stamps off the clock by at most :data:`JITTER_S` are jitter (Intel: 631
scans step back by < 0.9 s; sorting by stamp would make the odometry path 30 % longer): kept, and
made increasing by a running maximum whose runs of equal values are spread evenly to the next value
(:func:`strictly_increasing`; ``meta["time_adjusted_messages"]`` counts the changed ones).
A message whose stamp is zero, negative, not finite or off the clock by more than that (one ODOM
stamped 50 s late, say) is dropped — its neighbours carry the motion across — listed in
``meta["dropped_lines"]["bad_timestamp"]`` and warned about (:class:`DataWarning`); one line never
changes the time base of the log. Only a log whose stamps carry no time — most of a stream off its
clock, or most alike (several corrected logs stamp everything 0, with one value or a few) — gets ``t`` = the
scan index (``meta["time_source"]``, with a warning). ``strict_time=True`` raises at the first
stamp stepping back instead. The original stamps of the scans read are kept in
``meta["scan_ipc_timestamp"]``: relations files (Kümmerle et al.) refer to them; the log's relations file, where one is
staged or given (``relations``), is ``meta["relations"]``, which the relation metric scores by default.
"""

from __future__ import annotations

import bisect
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
from pydantic import PositiveFloat, PositiveInt, model_validator

from slamarena.params import Field, Params, with_params

from ..errors import DataFormatError, DataWarning
from ..geometry import between
from ..sequence import Increments, Noise, Scans, Sequence, Trajectory
from ..source import Layout, SourceParams
from ._physical import Bound, dropped_lines, outside
from ._text import Lines, binary_lines, check_monotonic, fixed, numbers, records

__all__ = ["read", "load", "CarmenParams", "CarmenSource", "beam_angles", "beam_step", "clock_faults", "JITTER_S"]

#: largest distance of an ipc timestamp from its stream's clock treated as jitter (clamped), seconds
JITTER_S = 1.0
_NAME = re.compile(r"^[A-Z][A-Z0-9_\-]*$")

#: physical ranges (research/method/data-validation.md): a message with a value outside is dropped (``out_of_range``)
POSITION = Bound(-1e5, 1e5, "m", "x, y of a pose: the staged logs span ≤ 211 m; 100 km bounds any ground robot's log")
HEADING = Bound(
    -1e4, 1e4, "rad", "θ of a pose: some loggers do not wrap (mit-csail reaches 11.1 rad); 1600 turns bound any log"
)
READING = Bound(
    0.0, 1000.0, "m", "a laser reading: 2D lidars of these logs return ≤ 81.91 m (SICK LMS); none reads negative"
)


def beam_step(n: int) -> float:
    """FLASER angular step: 180° in n beams; even n → π/n, odd n → π/(n−1) (both ends included)."""
    return np.pi / n if n % 2 == 0 else np.pi / max(n - 1, 1)


def beam_angles(n: int) -> np.ndarray:
    """FLASER beam angles: 180° from −90° in steps of :func:`beam_step`."""
    return -np.pi / 2 + beam_step(n) * np.arange(n)


def _heads(lines: Lines, rows: np.ndarray) -> list[str]:
    """Numeric part of messages ending in ``ts host lts``: the tag and ``host lts`` removed."""
    out = []
    for r in rows:
        parts = lines[r].split(None, 1)
        tail = parts[1].rsplit(None, 2) if len(parts) > 1 else []
        out.append(tail[0] if len(tail) == 3 else "")
    return out


def _fail(lines: Lines, row: int, expected: str) -> DataFormatError:
    return DataFormatError(lines.path, row + 1, expected, lines[row][:100])


def _flaser(lines: Lines, rows: np.ndarray):
    heads = _heads(lines, rows)
    values, counts = numbers(lines.path, heads, rows + 1, "a FLASER message")
    off = np.cumsum(counts) - counts
    has_n = counts > 0
    n = np.where(has_n, values[np.minimum(off, max(values.size - 1, 0))] if values.size else 0, -1)
    bad = np.flatnonzero(~has_n | (n != np.round(n)) | (n < 0) | (counts != n + 8))
    if bad.size:
        raise _fail(lines, int(rows[bad[0]]), "FLASER n r_1..r_n x y theta odom_x odom_y odom_theta ts host lts")
    n = n.astype(np.int64)
    tail = off + 1 + n
    laser = values[tail[:, None] + np.arange(3)]
    odom = values[tail[:, None] + 3 + np.arange(3)]
    ts = values[tail + 6]
    return values, off + 1, n, laser, odom, ts, None, None


def _robotlaser(lines: Lines, rows: np.ndarray):
    heads = _heads(lines, rows)
    values, counts = numbers(lines.path, heads, rows + 1, "a ROBOTLASER1 message")
    off = np.cumsum(counts) - counts
    expected = "ROBOTLASER1 type start fov res max_range accuracy mode n r.. m rem.. laser_pose robot_pose tv rv 3 more ts host lts"
    ok = counts >= 9
    n = np.full(len(rows), -1.0)
    n[ok] = values[off[ok] + 7]
    ok &= (n == np.round(n)) & (n >= 0) & (counts >= n + 9)
    m = np.full(len(rows), -1.0)
    m[ok] = values[off[ok] + 8 + n[ok].astype(np.int64)]
    ok &= (m == np.round(m)) & (m >= 0) & (counts == n + m + 21)
    bad = np.flatnonzero(~ok)
    if bad.size:
        raise _fail(lines, int(rows[bad[0]]), expected)
    n = n.astype(np.int64)
    m = m.astype(np.int64)
    tail = off + 9 + n + m
    laser = values[tail[:, None] + np.arange(3)]
    robot = values[tail[:, None] + 3 + np.arange(3)]
    ts = values[tail + 11]
    start, res, max_range = values[off + 1], values[off + 3], values[off + 4]
    return values, off + 8, n, laser, robot, ts, (start, res), max_range


def _longest_non_decreasing(t: np.ndarray) -> np.ndarray:
    """Mask of a longest subsequence of ``t`` that never decreases (patience sorting, O(n log n))."""
    tails: list[float] = []  # tails[k]: the smallest last value of a non-decreasing run of length k + 1 so far
    ends: list[int] = []  # ends[k]: its index
    prev = np.full(t.size, -1)
    for i, x in enumerate(t.tolist()):
        k = bisect.bisect_right(tails, x)
        if k == len(tails):
            tails.append(x)
            ends.append(i)
        else:
            tails[k], ends[k] = x, i
        prev[i] = ends[k - 1] if k else -1
    on = np.zeros(t.size, dtype=bool)
    i = ends[-1] if ends else -1
    while i >= 0:
        on[i] = True
        i = prev[i]
    return on


def strictly_increasing(t: np.ndarray) -> np.ndarray:
    """The running maximum of ``t`` with every run of equal values spread evenly over the interval to the next value,
    at most one median step of the stream (so a stamp moves at most that much beyond the running maximum), so that a
    stream's stamps increase strictly: jitter clamped to the same stamp would otherwise give two poses at one time
    (Intel: 1612 scans), which trajectories cannot hold."""
    t = np.maximum.accumulate(np.asarray(t, dtype=float))
    if t.size < 2 or np.all(np.diff(t) > 0):
        return t
    starts = np.flatnonzero(np.r_[True, np.diff(t) > 0])  # first index of each run of equal values
    length = np.diff(np.r_[starts, t.size])
    steps = np.diff(t[starts])
    median = np.median(steps) if steps.size else 1.0
    step = (
        np.minimum(np.r_[steps, median], median) / length
    )  # each run's share of the gap to the next, at most one median step
    run = np.repeat(np.arange(starts.size), length)
    return t[starts][run] + (np.arange(t.size) - starts[run]) * step[run]


def clock_faults(ts: np.ndarray) -> np.ndarray:
    """Messages whose stamp is not on their stream's clock (mask): zero, negative or not finite, or more than
    :data:`JITTER_S` before the clock's last stamp before it or after its first stamp after it. The clock is the
    longest subsequence of the valid stamps that never steps back in file order."""
    faults = ~(np.isfinite(ts) & (ts > 0))
    valid = np.flatnonzero(~faults)
    t = ts[valid]
    if t.size == 0 or (np.maximum.accumulate(t) - t).max() <= JITTER_S:
        return faults  # jitter at most: the running maximum is the clock
    on = _longest_non_decreasing(t)
    before = np.maximum.accumulate(np.where(on, t, -np.inf))
    after = np.minimum.accumulate(np.where(on, t, np.inf)[::-1])[::-1]
    faults[valid[~on & ((t < before - JITTER_S) | (t > after + JITTER_S))]] = True
    return faults


def _carries_time(ts: np.ndarray, faults: np.ndarray) -> bool:
    """Most stamps of the stream are on its clock, and most of those are distinct (the clock advances: not all alike,
    nor a few values repeated, as the corrected CSAIL log's 406 scans carry 2 distinct stamps)."""
    good = ts[~faults]
    return ts.size == 0 or (2 * good.size > ts.size and (good.size == 1 or 2 * np.unique(good).size > good.size))


def _dropped(path: str, rows: np.ndarray, reason: str) -> list[int]:
    """The 1-based line numbers of the dropped messages (0-based ``rows``), announced by one warning."""
    return dropped_lines(path, np.asarray(rows) + 1, reason, noun="message")


def _params(lines: Lines, rows: np.ndarray) -> dict:
    out = {}
    for r in rows:
        parts = lines[r].split()
        if len(parts) >= 3:
            out[parts[1]] = parts[2]
    return out


def _interlaced_with(chosen: int, n: np.ndarray, start: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Layouts that interlace with layout ``chosen``: the same angular step, a start less than one
    step away, and at most one beam more or fewer (the same field of view within one step)."""
    tol = 1e-6
    return (
        (np.abs(step - step[chosen]) <= tol)
        & (np.abs(start - start[chosen]) < step[chosen] - tol)
        & (np.abs(n - n[chosen]) <= 1)
    )


class CarmenParams(Params):
    """Options of the CARMEN reader (:func:`read`, :func:`load`)."""

    max_range: PositiveFloat | None = Field(
        None,
        description="readings >= max_range are no return [m] (the log's sentinel); "
        "None: ROBOTLASER1's stated max range, else the largest reading",
    )
    corrected: bool = Field(
        False, description="a SLAM-corrected log: its scan poses are the ground truth, echo ODOM lines are skipped"
    )
    odometry_scan_pose: bool = Field(
        False,
        description="a corrected log: each scan's pose (Scans.pose) is the raw odometry pose before it, not the corrected "
        "pose, so that a mapper runs on the odometry only; the corrected poses stay the ground truth",
    )
    beams: PositiveInt | None = Field(
        None,
        description="keep only the most common layout with this many beams (no interlacing); None: the most common layout",
    )
    interlaced: bool = Field(
        True, description="keep the layouts that interlace with the chosen one (angle_offset, beam_count)"
    )
    strict_time: bool = Field(
        False, description="raise at the first timestamp stepping back instead of making stamps non-decreasing"
    )
    relations: Path | None = Field(
        None,
        description="a relations file of this log (Kümmerle et al. 2009), recorded as meta['relations'] for the relation metric; "
        "None: the catalogue's staged one, if any",
    )

    @model_validator(mode="after")
    def _odometry_of_corrected(self):
        if self.odometry_scan_pose and not self.corrected:
            raise ValueError(
                "odometry_scan_pose applies to a corrected log (corrected: true); a raw log's scan poses are its odometry"
            )
        return self


@with_params(CarmenParams)
def read(path: str | Path, name: str | None = None, /, *, params: CarmenParams) -> Sequence:
    """A CARMEN log as a :class:`Sequence` (see the module docstring)."""
    lines, tag, dropped = _messages(path)
    laser = _laser_messages(lines, tag)
    odom, echo = _odometry(lines, tag, laser, params.corrected)
    odom, absurd_scan = _drop_out_of_range(lines, laser, odom, dropped)
    layouts = _layouts(lines.path, laser, params)
    keep = layouts.keep & ~absurd_scan
    odom, keep, scan_t, odo_t, meta = _time(lines, laser, odom, keep, params, dropped)
    ranges, angles, angle_offset, beam_count = _ranges(laser, layouts, keep)
    mounts = between(laser.robot[keep], laser.pose[keep])
    mount = np.median(mounts, axis=0)
    motion, truth, initial, scan_odom = _motion(laser, odom, keep, scan_t, odo_t, params.corrected, meta)
    if params.odometry_scan_pose:
        if scan_odom is None:
            raise DataFormatError(lines.path, None, "raw ODOM lines (odometry_scan_pose)", "none")
        meta["scan_pose_source"] = "raw ODOM pose before each scan (odometry_scan_pose)"
    max_range = _max_range(laser, keep, ranges, params.max_range, meta)
    scans = Scans(
        t=scan_t,
        ranges=ranges,
        angles=angles,
        max_range=max_range,
        mount=mount,
        pose=scan_odom if params.odometry_scan_pose else laser.robot[keep],
        angle_offset=angle_offset,
        beam_count=beam_count,
    )
    present = [t for t in np.unique(tag) if t]
    ignored = {str(t): int((tag == t).sum()) for t in present if t not in ("ODOM", "FLASER", "ROBOTLASER1", "PARAM")}
    meta.update(
        {
            "format": "CARMEN log",
            "file": lines.path,
            "corrected": params.corrected,
            "scan_message": laser.message,
            "scans": int(keep.sum()),
            "odom_messages": int(len(odom.values)),
            **echo,
            "dropped_scans_other_layout": layouts.dropped,
            "dropped_lines": dropped,
            "interlaced": bool(layouts.members.sum() > 1),
            "beam_layouts": layouts.table(),
            "no_return_readings": int((ranges >= max_range).sum()),
            "mount_spread": float(np.abs(mounts - mount).max()) if mounts.size else 0.0,
            "ignored_messages": ignored,
            "params": _params(lines, np.flatnonzero(tag == "PARAM")),
            "scan_ipc_timestamp": laser.ts[keep],
            "odom_ipc_timestamp": odom.ts,
            "noise": "not stated by the log",
        }
    )
    if params.relations is not None:
        meta["relations"] = str(params.relations)
    return Sequence(
        name=name or Path(path).name,
        motion=motion,
        scans=scans,
        ground_truth=truth,
        initial_pose=initial,
        noise=Noise(),
        meta=meta,
    )


@dataclass
class _Laser:
    """The laser messages of a log (one of FLASER, ROBOTLASER1), S of them: their 0-based lines ``rows`` (S,), the
    numbers of all ``values`` with each message's first reading at ``first`` (S,) and ``n`` (S,) readings, the laser
    ``pose`` and ``robot`` pose (S, 3), ipc stamps ``ts`` (S,), the stated ``layout`` (start, res) and max range (S,)
    (ROBOTLASER1; None for FLASER)."""

    message: str
    rows: np.ndarray
    values: np.ndarray
    first: np.ndarray
    n: np.ndarray
    pose: np.ndarray
    robot: np.ndarray
    ts: np.ndarray
    layout: tuple[np.ndarray, np.ndarray] | None
    stated_max: np.ndarray | None


@dataclass
class _Odometry:
    """The ODOM messages kept so far: ``values`` (N, 7) (x y θ tv rv accel ts), stamps ``ts`` (N,), 0-based lines
    ``rows`` (N,)."""

    values: np.ndarray
    ts: np.ndarray
    rows: np.ndarray

    def without(self, drop: np.ndarray) -> _Odometry:
        """The messages but those of the mask ``drop`` (N,)."""
        return _Odometry(self.values[~drop], self.ts[~drop], self.rows[~drop])


@dataclass
class _Layouts:
    """The beam layouts (L distinct): beams ``n`` (L,), ``start`` and ``step`` (L,) [rad], ``counts`` (L,) of scans,
    each scan's layout ``inverse`` (S,), the ``chosen`` one and the ``members`` (L,) kept with it; ``keep`` (S,) the
    scans of a member layout, ``dropped`` the others' count."""

    n: np.ndarray
    start: np.ndarray
    step: np.ndarray
    counts: np.ndarray
    inverse: np.ndarray
    chosen: int
    members: np.ndarray
    keep: np.ndarray
    dropped: int

    def table(self) -> list[dict]:
        """``meta["beam_layouts"]``: one row per layout, the offset of a member from the smallest start."""
        offset = self.start - float(self.start[self.members].min())
        return [
            {
                "beams": int(self.n[k]),
                "start": float(self.start[k]),
                "step": float(self.step[k]),
                "scans": int(self.counts[k]),
                "chosen": bool(self.members[k]),
                "angle_offset": float(offset[k]) if self.members[k] else None,
            }
            for k in range(len(self.n))
        ]


def _messages(path) -> tuple[Lines, np.ndarray, dict]:
    """The log's lines, each line's message name (``""``: none, or binary garbage, dropped and warned about) and the
    dropped lines so far (``{"binary_garbage": [line, …]}``); a name that is no upper-case identifier raises."""
    lines, tag = records(path, "CARMEN messages")
    garbage = binary_lines(lines)
    tag[garbage] = ""
    dropped = {"binary_garbage": _dropped(lines.path, garbage, "holding binary garbage")}
    for t in np.unique(tag):
        if t and not _NAME.match(t):
            raise _fail(lines, int(np.flatnonzero(tag == t)[0]), "a CARMEN message name (upper-case identifier)")
    return lines, tag, dropped


def _laser_messages(lines: Lines, tag: np.ndarray) -> _Laser:
    """The log's laser messages, parsed (FLASER or ROBOTLASER1: both in one log, or neither, raise)."""
    flaser_rows = np.flatnonzero(tag == "FLASER")
    rl_rows = np.flatnonzero(tag == "ROBOTLASER1")
    if flaser_rows.size and rl_rows.size:
        raise _fail(
            lines, int(max(flaser_rows[0], rl_rows[0])), "one laser message type per log (FLASER or ROBOTLASER1)"
        )
    rows = flaser_rows if flaser_rows.size else rl_rows
    if not rows.size:
        raise DataFormatError(lines.path, None, "FLASER or ROBOTLASER1 messages", "none")
    parse = _flaser if flaser_rows.size else _robotlaser
    return _Laser("FLASER" if flaser_rows.size else "ROBOTLASER1", rows, *parse(lines, rows))


def _odometry(lines: Lines, tag: np.ndarray, laser: _Laser, corrected: bool) -> tuple[_Odometry, dict]:
    """The ODOM messages, without a corrected log's echoes of its scan poses (the ODOM line right after a scan), and
    the counts for meta (echoes skipped, echoes matching the scan's pose, ODOM stamped 0)."""
    odom_rows = np.flatnonzero(tag == "ODOM")
    scan_rows = laser.rows
    odo = fixed(
        lines.path, _heads(lines, odom_rows), odom_rows + 1, 7, "an ODOM message (x y theta tv rv accel ts host lts)"
    )
    odo_ts = odo[:, 6]
    # corrected logs echo each scan's corrected pose in the ODOM line right after it (usually with
    # timestamp 0; some echoes carry garbage stamps, and freiburg-campus stamps ALL odometry 0)
    after = np.searchsorted(scan_rows, odom_rows) - 1
    messages = np.flatnonzero(tag != "")
    pos = np.searchsorted(messages, odom_rows)
    prev_line = np.where(pos > 0, messages[np.maximum(pos - 1, 0)], -1) if odom_rows.size else odom_rows
    echo = np.isin(prev_line, scan_rows) if corrected else np.zeros(len(odo), dtype=bool)
    echo_matches = (
        int((echo & np.all(np.abs(odo[:, :3] - laser.robot[np.clip(after, 0, None)]) < 1e-3, axis=1)).sum())
        if corrected
        else 0
    )
    counts = {
        "skipped_echo_odom": int(echo.sum()),
        "echo_odom_matching_scan_pose": echo_matches,
        "zero_time_odom": int((odo_ts == 0).sum()),
    }
    return _Odometry(odo, odo_ts, odom_rows).without(echo), counts


def _drop_out_of_range(lines: Lines, laser: _Laser, odom: _Odometry, dropped: dict) -> tuple[_Odometry, np.ndarray]:
    """Messages with a value outside its physical range dropped and listed (``dropped["out_of_range"]``): the ODOM
    messages kept, and the mask (S,) of the laser messages to drop."""
    odo = odom.values
    absurd_odom, why_odom = outside(
        {"ODOM x": (odo[:, 0], POSITION), "ODOM y": (odo[:, 1], POSITION), "ODOM theta": (odo[:, 2], HEADING)}
    )
    bad_value = np.r_[0, np.cumsum(READING.outside(laser.values))]
    pose_fields = {
        f"{which} {c}": (pose[:, k], bound)
        for which, pose in (("scan pose", laser.pose), ("robot pose", laser.robot))
        for k, (c, bound) in enumerate(zip(("x", "y", "theta"), (POSITION, POSITION, HEADING)))
    }
    absurd_scan, why_scan = outside(pose_fields)
    reading = bad_value[laser.first + laser.n] > bad_value[laser.first]
    absurd_scan |= reading
    dropped["out_of_range"] = _dropped(
        lines.path,
        np.concatenate([odom.rows[absurd_odom], laser.rows[absurd_scan]]),
        "; ".join(w for w in (why_odom, why_scan, f"a reading outside {READING}" if reading.any() else "") if w),
    )
    return odom.without(absurd_odom), absurd_scan


def _layouts(path: str, laser: _Laser, params: CarmenParams) -> _Layouts:
    """The scans' beam layouts: the most common one (or ``beams=``), plus its interlaced partners (``interlaced``)."""
    n, layout = laser.n, laser.layout
    key = np.column_stack([n, *(np.round(a, 6) for a in layout)]) if layout else n[:, None]
    layouts, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    n_l = layouts[:, 0].astype(np.int64)
    start_l = np.full(len(n_l), -np.pi / 2) if layout is None else layouts[:, 1]
    step_l = np.array([beam_step(int(b)) for b in n_l]) if layout is None else layouts[:, 2]
    if params.beams is None:
        chosen = int(np.argmax(counts))
    else:
        matches = np.flatnonzero(n_l == params.beams)
        if not matches.size:
            raise ValueError(f"{path}: no scans with {params.beams} beams (layouts: {n_l.tolist()})")
        chosen = int(matches[np.argmax(counts[matches])])
    members = np.zeros(len(layouts), dtype=bool)
    members[chosen] = True
    if params.interlaced and params.beams is None:
        members |= _interlaced_with(chosen, n_l, start_l, step_l)
    keep = members[inverse]
    return _Layouts(n_l, start_l, step_l, counts, inverse, chosen, members, keep, int((~keep).sum()))


def _time(lines: Lines, laser: _Laser, odom: _Odometry, keep: np.ndarray, params: CarmenParams, dropped: dict):
    """The time of the kept scans and ODOM messages (per stream: its clock, jitter clamped by a running maximum,
    faults dropped and listed in ``dropped["bad_timestamp"]``; else the scan index): the ODOM messages and scans (S,)
    kept, the scan stamps (S_kept,), the ODOM stamps (N,) and meta's ``time_source`` / ``time_adjusted_messages``."""
    meta: dict = {}
    scan_ts, scan_rows = laser.ts, laser.rows
    if params.strict_time:
        check_monotonic(lines.path, odom.ts, odom.rows + 1, "ODOM ipc timestamps")
        check_monotonic(lines.path, scan_ts, scan_rows + 1, "scan ipc timestamps")
    timed = np.flatnonzero(
        keep
    )  # the scans of the stream; ODOM stamps count in a raw log only (a corrected log places its odometry by its scans)
    scan_faults = clock_faults(scan_ts[timed])
    odo_faults = clock_faults(odom.ts) if not params.corrected else np.zeros(len(odom.values), dtype=bool)
    if _carries_time(scan_ts[timed], scan_faults) and (params.corrected or _carries_time(odom.ts, odo_faults)):
        dropped["bad_timestamp"] = _dropped(
            lines.path,
            np.concatenate([scan_rows[timed[scan_faults]], odom.rows[odo_faults]]),
            f"their ipc timestamp zero, negative or more than {JITTER_S:g} s off the clock of the log",
        )
        keep[timed[scan_faults]] = False
        odom = odom.without(odo_faults)
        scan_t = strictly_increasing(scan_ts[keep])
        odo_t = strictly_increasing(odom.ts) if odom.ts.size else odom.ts
        meta["time_source"] = (
            "ipc_timestamp (running maximum within each message type, equal stamps spread to the next)"
        )
        meta["time_adjusted_messages"] = int(
            (scan_t != scan_ts[keep]).sum() + (0 if params.corrected else (odo_t != odom.ts).sum())
        )
    else:
        # the stamps carry no time: the scan index; each ODOM at the index of the next scan in file order
        scan_t = np.arange(keep.sum(), dtype=float)
        odo_t = np.searchsorted(scan_rows[keep], odom.rows).astype(float)
        meta["time_source"] = "scan index (ipc timestamps zero, negative, alike or off their clock in most messages)"
        meta["time_adjusted_messages"] = 0
        dropped["bad_timestamp"] = []
        warnings.warn(
            f"{lines.path}: the ipc timestamps carry no time (zero, negative, alike or off their clock in most "
            "messages): t is the scan index",
            DataWarning,
        )
    return odom, keep, scan_t, odo_t, meta


def _ranges(laser: _Laser, layouts: _Layouts, keep: np.ndarray):
    """The kept scans' ranges (S_kept, B) float32 (NaN past a scan's beams), the angles (B,) from the smallest start of
    the member layouts, and for an interlaced stream each scan's angle offset and beam count (S_kept,), else None."""
    members = layouts.members
    B = int(layouts.n[members].max())
    base = float(layouts.start[members].min())
    angles = base + layouts.step[layouts.chosen] * np.arange(B)
    kept_n = laser.n[keep]
    beam = np.arange(B)[None, :] < kept_n[:, None]
    ranges = np.where(beam, laser.values[np.where(beam, laser.first[keep][:, None] + np.arange(B), 0)], np.nan).astype(
        np.float32
    )
    angle_offset = beam_count = None
    if members.sum() > 1:
        angle_offset = (layouts.start - base)[layouts.inverse[keep]]
        beam_count = kept_n
    return ranges, angles, angle_offset, beam_count


def _motion(laser: _Laser, odom: _Odometry, keep, scan_t, odo_t, corrected: bool, meta: dict):
    """The odometry increments, the ground truth (a corrected log's scan poses, else None), the initial pose and a
    corrected log's raw odometry pose at each scan (else None); meta's ``ground_truth_kind`` and ``motion_source``."""
    odo, robot = odom.values, laser.robot[keep]
    if corrected:
        # each scan's odometry = last raw ODOM pose before it in the file (else the first one)
        last = np.searchsorted(odom.rows, laser.rows[keep]) - 1
        motion = scan_odom = None
        if odo.shape[0]:
            scan_odom = odo[np.clip(last, 0, None), :3]
            motion = Increments(t=scan_t[1:], delta=between(scan_odom[:-1], scan_odom[1:]))
        meta["ground_truth_kind"] = "slam-reference"
        meta["motion_source"] = "raw ODOM pose before each scan, between consecutive scans"
        return motion, Trajectory(t=scan_t, poses=robot), laser.robot[keep][0], scan_odom
    if odo.shape[0] >= 2:
        motion = Increments(t=odo_t[1:], delta=between(odo[:-1, :3], odo[1:, :3]))
        initial = odo[0, :3]
        meta["motion_source"] = "ODOM poses, between consecutive messages"
    else:
        motion = Increments(t=scan_t[1:], delta=between(robot[:-1], robot[1:]))
        initial = robot[0]
        meta["motion_source"] = "odometry pose of each scan message (the log has no ODOM)"
    meta["ground_truth_kind"] = "none"
    return motion, None, initial, None


def _max_range(laser: _Laser, keep: np.ndarray, ranges: np.ndarray, given: float | None, meta: dict) -> float:
    """The no-return sentinel: ``given``, else ROBOTLASER1's stated max range, else the largest reading; its source in
    meta's ``max_range_source``."""
    if given is not None:
        meta["max_range_source"] = "given (the dataset's no-return sentinel)"
        return given
    stated = laser.stated_max
    meta["max_range_source"] = "ROBOTLASER1 max_range" if stated is not None else "largest reading of the log"
    return float(np.max(stated[keep])) if stated is not None else float(np.nanmax(ranges))


class CarmenSource(CarmenParams, SourceParams):
    """A CARMEN log (raw or SLAM-corrected: a property of the file) and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path", "corrected")
    path: str = Field(description="a CARMEN log file (.clf or .log, optionally .gz or .bz2)")

    def layout(self) -> Layout:
        return Layout({"log": (self.path,)})


@with_params(CarmenSource)
def load(files: dict, name: str, /, *, params: CarmenSource) -> Sequence:
    """The family reader: role ``log``, and the optional role ``relations`` (a catalogued log's staged relations file,
    used unless the options name one)."""
    options = params.options(CarmenParams)
    if options.relations is None and "relations" in files:
        options = options.model_copy(update={"relations": files["relations"]})
    return read(files["log"], name, params=options)
