"""TUM RGB-D trajectory files: ``timestamp x y z qx qy qz qw`` per line, ``#`` comments.

Planar poses map to TUM as z = 0 and a rotation θ about z: q = (0, 0, sin θ/2, cos θ/2).
Reading back, θ = 2·atan2(qz, qw) after normalising q; :func:`read` returns the full 3D rows
too, and :func:`to_se2` refuses rows that are not planar rotations about z (|qx|, |qy| > tol).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ..sequence import Trajectory
from ._text import check_monotonic, numeric_table

__all__ = ["TumTrajectory", "read", "read_trajectory", "write", "yaw_to_quaternion", "quaternion_to_yaw"]


@dataclass(frozen=True)
class TumTrajectory:
    t: np.ndarray
    xyz: np.ndarray
    quat: np.ndarray  # (N, 4) qx qy qz qw
    path: str = ""
    line: np.ndarray | None = None  # (N,) the 1-based line of each pose in the file

    def to_se2(self, tol: float = 1e-6) -> Trajectory:
        q = self.quat / np.linalg.norm(self.quat, axis=1, keepdims=True)
        tilted = np.flatnonzero((np.abs(q[:, :2]) > tol).any(axis=1))
        if tilted.size:
            raise ValueError(
                f"{self.path}: row {int(tilted[0])} is not a rotation about z (qx, qy = {q[tilted[0], :2]})"
            )
        return Trajectory(t=self.t, poses=np.column_stack([self.xyz[:, :2], quaternion_to_yaw(q)]))


def yaw_to_quaternion(theta: np.ndarray) -> np.ndarray:
    theta = np.asarray(theta, dtype=float)
    z = np.zeros_like(theta)
    return np.stack([z, z, np.sin(theta / 2), np.cos(theta / 2)], axis=-1)


def quaternion_to_yaw(q: np.ndarray) -> np.ndarray:
    return 2.0 * np.arctan2(q[..., 2], q[..., 3])


def read(path: str | Path) -> TumTrajectory:
    path = str(path)
    v, line = numeric_table(path, 8, "a TUM pose (timestamp x y z qx qy qz qw)")
    check_monotonic(path, v[:, 0], line, "TUM timestamps")
    norm = np.linalg.norm(v[:, 4:8], axis=1)
    bad = np.flatnonzero(~(norm > 0.5) | ~np.isfinite(v[:, 1:]).all(axis=1))
    if bad.size:
        raise DataFormatError(path, int(line[bad[0]]), "a finite pose with a unit quaternion", str(v[bad[0]].tolist()))
    return TumTrajectory(t=v[:, 0], xyz=v[:, 1:4], quat=v[:, 4:8], path=path, line=line)


def read_trajectory(path: str | Path) -> Trajectory:
    """A planar TUM file as a :class:`Trajectory`."""
    return read(path).to_se2()


def write(path: str | Path, t: np.ndarray, poses: np.ndarray, comment: str = "") -> None:
    """Write planar poses ``(N, 3)`` at times ``t`` as TUM lines (17 significant digits), after the column names and
    ``comment`` (its lines as ``#`` comments)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    table = np.column_stack(
        [np.asarray(t, dtype=float), poses[:, :2], np.zeros(len(poses)), yaw_to_quaternion(poses[:, 2])]
    )
    np.savetxt(path, table, fmt="%.17g", header="\n".join(filter(None, ["timestamp x y z qx qy qz qw", comment])))
