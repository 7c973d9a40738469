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

KITTI frames: ``"xy"`` (default) reads ``[R | t]`` as a pose in the x-y plane like the others; ``"camera"`` reads
KITTI odometry ground truth, the pose of a camera (x right, y down, z forward) in the first camera's frame:
``R_b = C R Cᵀ``, ``t_b = C t`` with ``C`` = :data:`CAMERA_TO_BODY` (x_b = z_c forward, y_b = −x_c left,
z_b = −y_c up), then planar as the others. A ``.txt`` file is TUM when its lines have 8 numbers and KITTI when they
have 12.

Planar poses are the x-y plane with a rotation about z (z = 0 when written, as :mod:`.tum` does). A pose's tilt is
the angle between its z axis and the world's, ``atan2(‖(R₂₀, R₂₁)‖, R₂₂)`` (for a quaternion ``2 asin ‖(qx, qy)‖``);
a pose tilted by more than ``max_tilt`` (default :data:`MAX_TILT`, 1e-6 rad) is refused, naming the file and line;
below it the pose is projected: yaw ``atan2(R₁₀, R₀₀)`` (the yaw of the ZYX Euler angles), position ``(x, y)``.
Writing a format without stamps (KITTI, g2o) drops ``t``: KITTI lines are in time order, g2o vertex ids are the
index.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..sequence import Trajectory
from . import g2o, tum
from ._text import check_monotonic, numeric_table

__all__ = ["FORMATS", "CAMERA_TO_BODY", "MAX_TILT", "format_of", "read", "write"]

FORMATS = ("tum", "kitti", "euroc", "g2o")
_SUFFIX = {".tum": "tum", ".kitti": "kitti", ".csv": "euroc", ".g2o": "g2o"}
#: default largest tilt of a pose out of the x-y plane [rad]: the angle between its z axis and the world's
MAX_TILT = 1e-6


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


def _tilt_of_quaternion(q: np.ndarray) -> np.ndarray:
    """Angle [rad] between the z axis of unit quaternions ``(x, y, z, w)`` (N, 4) and the world's: 2 asin √(x² + y²)."""
    return 2.0 * np.arcsin(np.clip(np.hypot(q[:, 0], q[:, 1]), 0.0, 1.0))


def _refuse_tilted(path: str, lines: np.ndarray, tilt: np.ndarray, max_tilt: float, rows: np.ndarray) -> None:
    bad = np.flatnonzero(tilt > max_tilt)
    if bad.size:
        k = int(bad[0])
        raise DataFormatError(
            path, int(lines[k]), f"a planar pose (tilt out of the x-y plane <= {max_tilt:g} rad)", str(rows[k].tolist())
        )


def _from_rotation(
    path: str, lines: np.ndarray, t: np.ndarray, xy: np.ndarray, R: np.ndarray, max_tilt: float
) -> Trajectory:
    """Planar poses from positions and rotation matrices (N, 3, 3): yaw ``atan2(R₁₀, R₀₀)``, refusing a tilt
    ``atan2(‖(R₂₀, R₂₁)‖, R₂₂)`` above ``max_tilt``."""
    _refuse_tilted(path, lines, np.arctan2(np.hypot(R[:, 2, 0], R[:, 2, 1]), R[:, 2, 2]), max_tilt, R)
    return Trajectory(t=t, poses=np.column_stack([xy, np.arctan2(R[:, 1, 0], R[:, 0, 0])]))


#: camera axes (x right, y down, z forward) → body axes (x forward, y left, z up): rows x_b = z_c, y_b = −x_c, z_b = −y_c
CAMERA_TO_BODY = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _kitti(path: str, times: str | Path | None, frame: str, max_tilt: float) -> Trajectory:
    v, line = numeric_table(path, 12, "a KITTI pose (the 3 x 4 matrix [R | t], 12 numbers)")
    M = v.reshape(-1, 3, 4)
    if frame == "camera":  # poses of a camera in the first camera's frame: both re-expressed in body axes
        C = CAMERA_TO_BODY
        M = np.concatenate([C @ M[:, :, :3] @ C.T, (C @ M[:, :, 3:])], axis=2)
    if times is None:
        t = np.arange(len(v), dtype=float)
    else:
        t, t_line = numeric_table(str(times), 1, "one time per line")
        t = t[:, 0]
        if t.size != len(v):
            raise DataFormatError(times, None, f"{len(v)} times (one per pose of {path})", f"{t.size}")
        check_monotonic(str(times), t, t_line, "KITTI times")
    return _from_rotation(path, line, t, M[:, :2, 3], M[:, :, :3], max_tilt)


def _euroc(path: str, max_tilt: float) -> Trajectory:
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
    _refuse_tilted(path, lines, _tilt_of_quaternion(q), max_tilt, v)
    return Trajectory(t=t, poses=np.column_stack([v[:, :2], tum.quaternion_to_yaw(q)]))


def _tum(path: str, max_tilt: float) -> Trajectory:
    raw = tum.read(path)
    q = raw.quat / np.linalg.norm(raw.quat, axis=1, keepdims=True)
    _refuse_tilted(path, raw.line, _tilt_of_quaternion(q), max_tilt, np.column_stack([raw.xyz, raw.quat]))
    return Trajectory(t=raw.t, poses=np.column_stack([raw.xyz[:, :2], tum.quaternion_to_yaw(q)]))


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


def read(
    path: str | Path,
    format: str | None = None,
    times: str | Path | None = None,
    kitti_frame: str = "xy",
    max_tilt: float = MAX_TILT,
) -> Trajectory:
    """The planar trajectory in ``path`` (format by suffix unless given; ``times``: KITTI's stamps file;
    ``kitti_frame``: ``"xy"`` or ``"camera"`` for KITTI files; poses tilted out of the x-y plane by more than
    ``max_tilt`` rad are refused, the others projected: see the module docstring)."""
    if kitti_frame not in ("xy", "camera"):
        raise ValueError(f"kitti_frame must be 'xy' or 'camera', got {kitti_frame!r}")
    format = format or format_of(path)
    path = str(path)
    if format == "tum":
        return _tum(path, max_tilt)
    if format == "kitti":
        return _kitti(path, times, kitti_frame, max_tilt)
    if format == "euroc":
        return _euroc(path, max_tilt)
    if format == "g2o":
        return _g2o(path)
    raise ValueError(f"unknown trajectory format {format!r}; known: {', '.join(FORMATS)}")


def write(
    path: str | Path, t: np.ndarray, poses: np.ndarray, format: str | None = None, kitti_frame: str = "xy"
) -> None:
    """Write planar ``poses`` (N, 3) at ``t`` in ``format`` (by suffix unless given; ``.txt`` is TUM; KITTI in
    ``kitti_frame``)."""
    format = format or (_SUFFIX.get(Path(path).suffix) or "tum")
    t = np.asarray(t, dtype=float)
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    if format == "tum":
        tum.write(path, t, poses)
    elif format == "kitti":
        z, o = np.zeros_like(c), np.ones_like(c)
        rows = np.column_stack([c, -s, z, poses[:, 0], s, c, z, poses[:, 1], z, z, o, z])
        if kitti_frame == "camera":
            C = CAMERA_TO_BODY
            M = rows.reshape(-1, 3, 4)
            rows = np.concatenate([C.T @ M[:, :, :3] @ C, C.T @ M[:, :, 3:]], axis=2).reshape(-1, 12) + 0.0
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
