"""Small ROS bags written by the tests with rosbags' writers (ROS 1, ROS 2 sqlite3, ROS 2 MCAP, bare MCAP).

:func:`robot_bag` writes a bag with every message type the bag reader reads and returns what it wrote, so the tests
compare the reader's Sequence with these numbers. Header stamps are ``t``, receive times ``t + RECEIVE_LAG``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.datasets.formats.bag_write import BagWriter
from slamarena.datasets.formats.ros_messages import header, message, pose2d, stamp
from slamarena.datasets.formats.tum import yaw_to_quaternion
from slamarena.datasets.geometry import compose

RECEIVE_LAG = 0.05
#: the laser's mounting as a TF chain base_link → laser_mount → laser, and the composed pose
MOUNT_LINKS = (np.array([0.20, 0.0, 0.3]), np.array([0.0, 0.10, 0.2]))
MOUNT = compose(*MOUNT_LINKS)
GPS_ORIGIN = (48.0, 11.0, 500.0)


def quaternion(yaw: float) -> dict:
    q = yaw_to_quaternion(yaw)
    return {"x": q[0], "y": q[1], "z": q[2], "w": q[3]}


def transform(ts, t: float, parent: str, child: str, pose: np.ndarray):
    """A TransformStamped of a planar pose ``(x, y, yaw)`` or of a 4 × 4 pose."""
    pose = np.asarray(pose, dtype=float)
    if pose.shape == (4, 4):
        from scipy.spatial.transform import Rotation

        x, y, z, w = Rotation.from_matrix(pose[:3, :3]).as_quat()
        body = {"translation": dict(zip("xyz", pose[:3, 3])), "rotation": {"x": x, "y": y, "z": z, "w": w}}
    else:
        body = {"translation": {"x": pose[0], "y": pose[1]}, "rotation": quaternion(pose[2])}
    return message(
        ts, "geometry_msgs/msg/TransformStamped", header=header(t, parent), child_frame_id=child, transform=body
    )


def robot_bag(
    path: Path,
    storage: str = "sqlite3",
    scan_stamps=None,
    cmd_vel: str = "Twist",
    mount_links=MOUNT_LINKS,
    angle_min=None,
) -> dict:
    """A bag at ``path`` with /scan, /odom, /tf_static, /tf, /cmd_vel, /gps, /imu and /truth; returns the values.

    ``scan_stamps``: the scans' header stamps (default 10.0 + 0.1 k; they are received at those times in any case);
    ``mount_links``: the two links of the laser's TF chain, each ``(x, y, yaw)`` or a 4 × 4 pose (None: no /tf_static);
    ``angle_min``: per scan (default −1 for all)."""
    n_scan, B = 5, 8
    t_scan = np.arange(n_scan) * 0.1 + 10.0 if scan_stamps is None else np.asarray(scan_stamps, dtype=float)
    t_odom = np.arange(11) * 0.05 + 9.95  # every other one at a scan stamp
    odom = np.column_stack([0.3 * (t_odom - 10), 0.1 * (t_odom - 10) ** 2, 0.5 * (t_odom - 10)])
    twist = np.column_stack([np.full(11, 0.3), np.full(11, 0.5)])
    ranges = np.full((n_scan, B), 5.0, dtype=np.float32) + np.arange(B, dtype=np.float32)[None] * 0.25
    ranges[0, 1], ranges[1, 2], ranges[2, 3], ranges[3, 4] = np.inf, np.nan, 0.05, 12.0
    intensities = np.arange(n_scan * B, dtype=np.float32).reshape(n_scan, B)
    t_cmd = np.arange(6) * 0.1 + 10.0
    cmd = np.column_stack([np.linspace(0.1, 0.6, 6), np.linspace(-0.2, 0.3, 6)])
    t_gps = np.arange(3) * 0.2 + 10.0
    d_lat = np.array([0.0, 1e-5, 2e-5])
    d_lon = np.array([0.0, 0.0, 1e-5])
    t_imu = np.arange(4) * 0.1 + 10.0
    imu_yaw = np.array([0.1, 0.2, -3.0, 3.1])
    imu_rate = np.array([0.5, 0.4, 0.3, 0.2])
    truth = odom + np.array([0.01, -0.01, 0.0])
    with BagWriter(path, storage=storage) as w:
        ts = w.typestore
        if mount_links is not None:
            w.write("/tf_static", 9.9, message(ts, "tf2_msgs/msg/TFMessage", transforms=[
                transform(ts, 9.9, "base_link", "laser_mount", mount_links[0]),
                transform(ts, 9.9, "laser_mount", "laser", mount_links[1]),
            ]))  # fmt: skip
        events = []
        for k, t in enumerate(t_odom):
            events.append((t, "/odom", message(
                ts, "nav_msgs/msg/Odometry", header=header(t, "odom"), child_frame_id="base_link",
                pose={"pose": pose2d(*odom[k])},
                twist={"twist": {"linear": {"x": twist[k, 0]}, "angular": {"z": twist[k, 1]}}},
            )))  # fmt: skip
            events.append((t, "/tf", message(ts, "tf2_msgs/msg/TFMessage", transforms=[
                transform(ts, t, "odom", "base_link", odom[k])])))  # fmt: skip
            events.append((t, "/truth", message(ts, "geometry_msgs/msg/PoseStamped", header=header(t, "map"),
                                                pose=pose2d(*truth[k]))))  # fmt: skip
        for k, t in enumerate(t_scan):  # received in index order at the nominal 10 Hz, whatever the header says
            events.append((10.0 + 0.1 * k, "/scan", message(
                ts, "sensor_msgs/msg/LaserScan", header=header(t, "laser"),
                angle_min=-1.0 if angle_min is None else angle_min[k],
                angle_max=-1.0 + 0.25 * (B - 1), angle_increment=0.25, range_min=0.1, range_max=10.0,
                ranges=ranges[k], intensities=intensities[k],
            )))  # fmt: skip
        for k, t in enumerate(t_cmd):
            body = {"linear": {"x": cmd[k, 0]}, "angular": {"z": cmd[k, 1]}}
            msg = (
                message(ts, "geometry_msgs/msg/Twist", **body)
                if cmd_vel == "Twist"
                else message(ts, "geometry_msgs/msg/TwistStamped", header=header(t, "base_link"), twist=body)
            )
            events.append((t, "/cmd_vel", msg))
        for k, t in enumerate(t_gps):
            events.append((t, "/gps", message(
                ts, "sensor_msgs/msg/NavSatFix", header=header(t, "gps"), status={"status": 0},
                latitude=GPS_ORIGIN[0] + d_lat[k], longitude=GPS_ORIGIN[1] + d_lon[k], altitude=GPS_ORIGIN[2],
                position_covariance=np.diag([4.0, 9.0, 16.0]).ravel(), position_covariance_type=2,
            )))  # fmt: skip
        for k, t in enumerate(t_imu):
            events.append((t, "/imu", message(
                ts, "sensor_msgs/msg/Imu", header=header(t, "imu"), orientation=quaternion(imu_yaw[k]),
                orientation_covariance=np.diag([1e-3, 1e-3, 2e-3]).ravel(), angular_velocity={"z": imu_rate[k]},
            )))  # fmt: skip
        for t, topic, msg in sorted(events, key=lambda e: e[0]):
            w.write(topic, t + RECEIVE_LAG, msg)
    return dict(
        t_scan=t_scan, t_odom=t_odom, odom=odom, twist=twist, ranges=ranges, intensities=intensities, t_cmd=t_cmd,
        cmd=cmd, t_gps=t_gps, d_lat=d_lat, d_lon=d_lon, t_imu=t_imu, imu_yaw=imu_yaw, imu_rate=imu_rate, truth=truth,
        stamp=stamp,
    )  # fmt: skip


def geodetic_of(enu: np.ndarray, origin: tuple[float, float, float]) -> np.ndarray:
    """(lat°, lon°, alt m) of east-north-up points ``enu`` (N, 3) at ``origin``: ENU → ECEF → geodetic by the
    fixed-point iteration of the latitude (Bowring's form), written here independently of the reader's projection."""
    from slamarena.datasets.formats.ros_convert import WGS84_A, WGS84_F, ecef_of

    phi, lam = np.radians(origin[0]), np.radians(origin[1])
    R = np.array(
        [
            [-np.sin(lam), np.cos(lam), 0.0],
            [-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)],
            [np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)],
        ]
    )
    xyz = ecef_of(np.array([origin[0]]), np.array([origin[1]]), np.array([origin[2]])) + enu @ R
    e2 = WGS84_F * (2 - WGS84_F)
    p = np.hypot(xyz[:, 0], xyz[:, 1])
    lat = np.arctan2(xyz[:, 2], p * (1 - e2))
    for _ in range(10):
        N = WGS84_A / np.sqrt(1 - e2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - N
        lat = np.arctan2(xyz[:, 2], p * (1 - e2 * N / (N + h)))
    return np.column_stack([np.degrees(lat), np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0])), h])


def localization_bag(seq, path: Path, origin=GPS_ORIGIN) -> None:
    """The Sequence of ``sim:localization`` as a bag: /cmd_vel (Twist, received at the command stamps), /gps
    (NavSatFix at ``origin``, its stated covariance), /imu (Imu yaw, its stated variance) and /truth (PoseStamped)."""
    lla = geodetic_of(np.column_stack([seq.gps.xy, np.zeros(len(seq.gps))]), origin)
    gps_cov = np.zeros((3, 3))
    gps_cov[:2, :2] = seq.noise.gps_cov
    with BagWriter(path) as w:
        ts = w.typestore
        events = [
            (t, "/cmd_vel", message(ts, "geometry_msgs/msg/Twist", linear={"x": v}, angular={"z": om}))
            for t, v, om in zip(seq.motion.t, seq.motion.v, seq.motion.omega)
        ]
        events += [
            (t, "/gps", message(ts, "sensor_msgs/msg/NavSatFix", header=header(t, "gps"), latitude=a, longitude=b,
                                altitude=c, position_covariance=gps_cov.ravel(), position_covariance_type=3))
            for t, (a, b, c) in zip(seq.gps.t, lla)
        ]  # fmt: skip
        events += [
            (t, "/imu", message(ts, "sensor_msgs/msg/Imu", header=header(t, "imu"), orientation=quaternion(yaw),
                                orientation_covariance=np.diag([1.0, 1.0, seq.noise.yaw_var]).ravel()))
            for t, yaw in zip(seq.heading.t, seq.heading.yaw)
        ]  # fmt: skip
        events += [
            (t, "/truth", message(ts, "geometry_msgs/msg/PoseStamped", header=header(t, "map"), pose=pose2d(*p)))
            for t, p in zip(seq.ground_truth.t, seq.ground_truth.poses)
        ]
        for t, topic, msg in sorted(events, key=lambda e: e[0]):
            w.write(topic, t, msg)
