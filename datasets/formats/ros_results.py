"""A result as ROS messages in an MCAP file (opens in Foxglove, plays into RViz 2 with ``ros2 bag play``).

Topics (frame ``map``; stamps = the estimate's times, which must be ≥ 0 s; receive time = stamp):

* ``/tf`` (``tf2_msgs/TFMessage``): one ``map → base_link`` transform per pose, at its stamp;
* ``/trajectory`` (``nav_msgs/Path``): every pose as a ``PoseStamped``, one message at the last stamp;
* ``/map`` (``nav_msgs/OccupancyGrid``), when a grid is given: ``data`` row-major from the cell at ``origin``
  (the lower-left corner of cell (0, 0)), rows along y; 0 free, 100 occupied, −1 unknown; at the last stamp;
* ``/landmarks`` (``visualization_msgs/MarkerArray``), when landmarks are given: one ``SPHERE`` per landmark,
  ``ns = "landmarks"``, ``id`` = the landmark id, diameter ``LANDMARK_DIAMETER``; at the last stamp.

Written with rosbags' ROS 2 writer (:class:`~.bag_write.BagWriter`, CDR, ROS 2 Humble types).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .bag_write import BagWriter
from .ros_messages import header, message, pose2d

__all__ = ["Grid", "write", "LANDMARK_DIAMETER", "FRAME", "BASE"]

LANDMARK_DIAMETER = 0.3
FRAME, BASE = "map", "base_link"


@dataclass(frozen=True)
class Grid:
    """An occupancy grid in ROS form: ``data`` (H, W) int8 (rows = y), cell size [m], lower-left corner (x, y)."""

    data: np.ndarray
    resolution: float
    origin: tuple[float, float]


def write(
    path: str | Path,
    t: np.ndarray,
    poses: np.ndarray,
    grid: Grid | None = None,
    landmarks: tuple[np.ndarray, np.ndarray] | None = None,
) -> None:
    """Write poses (N, 3) at ``t`` (N,), and optionally a grid and landmarks ``(ids (L,), xy (L, 2))``, to ``path``
    (a ``.mcap`` file; module docstring)."""
    t = np.asarray(t, dtype=float)
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    if not len(t) or t.min() < 0:
        raise ValueError("an MCAP result needs at least one pose and stamps >= 0 s")
    end = float(t[-1])
    with BagWriter(path) as w:
        ts = w.typestore
        stamped = []
        for tk, p in zip(t, poses):
            pose = pose2d(*p)
            stamped.append(message(ts, "geometry_msgs/msg/PoseStamped", header=header(tk, FRAME), pose=pose))
            transform = {"translation": pose["position"], "rotation": pose["orientation"]}
            tf = message(ts, "geometry_msgs/msg/TransformStamped", header=header(tk, FRAME), child_frame_id=BASE,
                         transform=transform)  # fmt: skip
            w.write("/tf", tk, message(ts, "tf2_msgs/msg/TFMessage", transforms=[tf]))
        w.write("/trajectory", end, message(ts, "nav_msgs/msg/Path", header=header(end, FRAME), poses=stamped))
        if grid is not None:
            h, width = grid.data.shape
            info = {
                "map_load_time": header(end, "")["stamp"],
                "resolution": float(grid.resolution),
                "width": width,
                "height": h,
                "origin": pose2d(grid.origin[0], grid.origin[1], 0.0),
            }
            data = np.ascontiguousarray(grid.data, dtype=np.int8).ravel()
            w.write(
                "/map", end, message(ts, "nav_msgs/msg/OccupancyGrid", header=header(end, FRAME), info=info, data=data)
            )
        if landmarks is not None:
            d = LANDMARK_DIAMETER
            markers = [
                message(ts, "visualization_msgs/msg/Marker", header=header(end, FRAME), ns="landmarks", id=int(i),
                        type=2, action=0, pose=pose2d(x, y, 0.0), scale={"x": d, "y": d, "z": d},
                        color={"r": 0.9, "g": 0.4, "b": 0.1, "a": 1.0})
                for i, (x, y) in zip(np.asarray(landmarks[0]), np.asarray(landmarks[1]).reshape(-1, 2))
            ]  # fmt: skip
            w.write("/landmarks", end, message(ts, "visualization_msgs/msg/MarkerArray", markers=markers))
