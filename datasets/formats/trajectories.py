"""Trajectory files of other systems, read and written as a planar :class:`Trajectory` ``(t, x, y, θ)``.

=========  ============  ================================================================================
format     suffix        one pose per line
=========  ============  ================================================================================
``tum``    ``.tum``      ``t x y z qx qy qz qw`` (:mod:`.tum`; t in seconds)
``kitti``  ``.kitti``    ``r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz``: the 3 × 4 matrix ``[R | t]`` row by
                         row (KITTI odometry poses); no stamps: ``t`` = the line index, or a ``times`` file
                         (KITTI's ``times.txt``, one time per line)
``euroc``  ``.csv``      ``timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z[, …]`` (EuRoC / ASL ground truth:
                         the quaternion **w first**, time in integer nanoseconds; columns after the eighth
                         — velocities, biases — ignored; a ``#`` header line)
``g2o``    ``.g2o``      ``VERTEX_SE2 id x y θ`` (read by :mod:`.g2o`, edges allowed): ``t`` = the vertex id
=========  ============  ================================================================================

A ``.txt`` file is TUM when its lines have 8 numbers and KITTI when they have 12. Planar poses are the x-y plane
with a rotation about z (z = 0 when written, as :mod:`.tum` does); a pose tilted out of that plane (|qx|, |qy| or
|r13|, |r23|, |r31|, |r32| above 1e-6) is refused, naming the file and line. Writing a format without stamps
(KITTI, g2o) drops ``t``: KITTI lines are in time order, g2o vertex ids are the index.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..sequence import Trajectory
from . import g2o, tum
from ._text import check_monotonic, numeric_table

__all__ = ["FORMATS", "format_of", "read", "write"]

FORMATS = ("tum", "kitti", "euroc", "g2o")
_SUFFIX = {".tum": "tum", ".kitti": "kitti", ".csv": "euroc", ".g2o": "g2o"}
_TILT = 1e-6


def format_of(path: str | Path) -> str:
    """The format of ``path`` by its suffix (``.txt``: by the number of columns of its first data line)."""
    path = Path(path)
    if path.suffix in _SUFFIX:
        return _SUFFIX[path.suffix]
    if path.suffix == ".txt":
        for line in path.read_text().splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                n = len(line.split())
                if n in (8, 12):
                    return "tum" if n == 8 else "kitti"
                raise DataFormatError(path, None, "8 columns (TUM) or 12 (KITTI) per line", f"{n} columns")
    raise DataFormatError(
        path, None, f"a trajectory file ({', '.join(sorted(_SUFFIX))}, .txt) or --format", path.suffix
    )


def _from_rotation(path: str, lines: np.ndarray, t: np.ndarray, xy: np.ndarray, R: np.ndarray) -> Trajectory:
    """Planar poses from positions and rotation matrices (N, 3, 3), refusing rotations not about z."""
    tilt = np.abs(np.stack([R[:, 0, 2], R[:, 1, 2], R[:, 2, 0], R[:, 2, 1]], axis=1)).max(axis=1)
    bad = np.flatnonzero(tilt > _TILT)
    if bad.size:
        raise DataFormatError(path, int(lines[bad[0]]), "a rotation about z (a planar pose)", str(R[bad[0]].tolist()))
    return Trajectory(t=t, poses=np.column_stack([xy, np.arctan2(R[:, 1, 0], R[:, 0, 0])]))


def _kitti(path: str, times: str | Path | None) -> Trajectory:
    v, line = numeric_table(path, 12, "a KITTI pose (the 3 x 4 matrix [R | t], 12 numbers)")
    M = v.reshape(-1, 3, 4)
    if times is None:
        t = np.arange(len(v), dtype=float)
    else:
        t, t_line = numeric_table(str(times), 1, "one time per line")
        t = t[:, 0]
        if t.size != len(v):
            raise DataFormatError(times, None, f"{len(v)} times (one per pose of {path})", f"{t.size}")
        check_monotonic(str(times), t, t_line, "KITTI times")
    return _from_rotation(path, line, t, M[:, :2, 3], M[:, :, :3])


def _euroc(path: str) -> Trajectory:
    rows, lines = [], []
    for k, text in enumerate(Path(path).read_text().splitlines(), start=1):
        if not text.strip() or text.lstrip().startswith("#"):
            continue
        fields = text.split(",")
        try:
            rows.append([int(fields[0])] + [float(x) for x in fields[1:8]])
        except (ValueError, IndexError):
            raise DataFormatError(path, k, "timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z", text[:100]) from None
        lines.append(k)
    if not rows:
        raise DataFormatError(path, None, "EuRoC pose lines", "no data line")
    ns = np.array([r[0] for r in rows], dtype=np.int64)
    v = np.array([r[1:] for r in rows], dtype=float)
    lines = np.array(lines)
    t = ns / 1e9
    check_monotonic(path, t, lines, "EuRoC timestamps")
    q = v[:, [4, 5, 6, 3]]  # (x, y, z, w) from EuRoC's (w, x, y, z)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    bad = np.flatnonzero((np.abs(q[:, :2]) > _TILT).any(axis=1))
    if bad.size:
        raise DataFormatError(path, int(lines[bad[0]]), "a rotation about z (q_x = q_y = 0)", str(v[bad[0]].tolist()))
    return Trajectory(t=t, poses=np.column_stack([v[:, :2], tum.quaternion_to_yaw(q)]))


def _g2o(path: str) -> Trajectory:
    graph = g2o.read(path)
    if graph.dim != 2 or graph.poses is None:
        raise DataFormatError(
            path,
            None,
            "VERTEX_SE2 lines (a 2D graph with vertices)",
            f"{graph.dim}D, no vertices" if graph.poses is None else f"{graph.dim}D",
        )
    return Trajectory(t=np.asarray(graph.node_ids, dtype=float), poses=graph.poses)


def read(path: str | Path, format: str | None = None, times: str | Path | None = None) -> Trajectory:
    """The planar trajectory in ``path`` (format by suffix unless given; ``times``: KITTI's stamps file)."""
    format = format or format_of(path)
    path = str(path)
    if format == "tum":
        return tum.read_trajectory(path)
    if format == "kitti":
        return _kitti(path, times)
    if format == "euroc":
        return _euroc(path)
    if format == "g2o":
        return _g2o(path)
    raise ValueError(f"unknown trajectory format {format!r}; known: {', '.join(FORMATS)}")


def write(path: str | Path, t: np.ndarray, poses: np.ndarray, format: str | None = None) -> None:
    """Write planar ``poses`` (N, 3) at ``t`` in ``format`` (by suffix unless given; ``.txt`` is TUM)."""
    format = format or (_SUFFIX.get(Path(path).suffix) or "tum")
    t = np.asarray(t, dtype=float)
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    if format == "tum":
        tum.write(path, t, poses)
    elif format == "kitti":
        z, o = np.zeros_like(c), np.ones_like(c)
        rows = np.column_stack([c, -s, z, poses[:, 0], s, c, z, poses[:, 1], z, z, o, z])
        np.savetxt(path, rows, fmt="%.17g")
    elif format == "euroc":
        q = tum.yaw_to_quaternion(poses[:, 2])
        ns = np.round(t * 1e9).astype(np.int64)
        lines = ["#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w [],q_x [],q_y [],q_z []"]
        lines += [
            f"{n},{x:.17g},{y:.17g},0,{qw:.17g},{qx:.17g},{qy:.17g},{qz:.17g}"
            for n, (x, y, _), (qx, qy, qz, qw) in zip(ns, poses, q)
        ]
        Path(path).write_text("\n".join(lines) + "\n")
    elif format == "g2o":
        Path(path).write_text(
            "".join(f"VERTEX_SE2 {k} {x:.17g} {y:.17g} {th:.17g}\n" for k, (x, y, th) in enumerate(poses))
        )
    else:
        raise ValueError(f"unknown trajectory format {format!r}; known: {', '.join(FORMATS)}")
