"""KITTI velodyne scans (``.bin``): little-endian float32 ``x y z reflectance`` per point, no header.

Sensor frame: x forward, y left, z up (metres); reflectance in [0, 1].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFormatError

__all__ = ["read", "write"]


def read(path: str | Path) -> np.ndarray:
    """The points of one scan as an ``(N, 4)`` float32 array, N ≥ 1."""
    size = Path(path).stat().st_size
    if size == 0 or size % 16:
        raise DataFormatError(path, None, "a positive multiple of 16 bytes (4 float32 per point)", f"{size} bytes")
    return np.fromfile(path, dtype="<f4").reshape(-1, 4)


def write(path: str | Path, points: np.ndarray) -> None:
    points = np.asarray(points, dtype="<f4")
    if points.ndim != 2 or points.shape[1] != 4:
        raise ValueError("KITTI points must be (N, 4): x y z reflectance")
    points.tofile(path)
