"""ROS bags (ROS 1 ``.bag``, ROS 2 folders with sqlite3 or MCAP storage, bare ``.mcap``) as a :class:`Sequence`.

Read with ``rosbags`` (:mod:`.bag_io`; conversions in :mod:`.ros_convert`). Each stream comes from one topic: the
one named by its option, else the one topic of its type (several of a type: name one; none: the stream is absent):

================  =========================================  ==========================================
option            message type                               Sequence field
================  =========================================  ==========================================
``scan_topic``    ``sensor_msgs/LaserScan``                  ``scans`` (ranges float32, intensities)
``odom_topic``    ``nav_msgs/Odometry``                      ``scans.pose`` (odometry at each scan) and
                                                             ``motion`` (increments, or its twists)
``cmd_vel_topic`` ``geometry_msgs/Twist`` / ``TwistStamped``  ``motion`` (the EKF localizer's input)
``gps_topic``     ``sensor_msgs/NavSatFix``                  ``gps`` (local east-north, metres)
``imu_topic``     ``sensor_msgs/Imu``                        ``heading`` (yaw, yaw rate)
``truth_topic``   ``nav_msgs/Odometry`` / ``PoseStamped``    ``ground_truth`` (only when named)
================  =========================================  ==========================================

* ``motion``: ``"auto"`` = odometry increments ``between(pose_{k−1}, pose_k)`` at the odometry stamps when there is
  an odometry topic (``initial_pose`` = its first pose, as the CARMEN reader), else the cmd_vel twists
  (:meth:`Twist.from_stamps`: each command holds until the next); ``"odometry_twist"``: the odometry's own
  ``twist.linear.x``, ``twist.angular.z``; ``"cmd_vel"``, ``"odometry"``: that source or an error.
* ``scans.pose``: the odometry pose at each scan stamp (SE(2) interpolation between the odometry messages around
  it; NaN outside their span). ``scans.mount``: the laser frame (the scans' ``header.frame_id``) in the base frame
  (``base_frame``, else the odometry's ``child_frame_id``, else ``base_link``) from ``/tf_static`` and ``/tf``
  (:func:`~.ros_convert.mount_from_tf`); the same frame, or no chain (warned), is the identity; an upside-down laser
  gets negated beam angles (:func:`~.ros_convert.planar_mount`).
  ``max_range``: the largest ``range_max`` (or the option).
* ``gps``: fixes with a fix (``status ≥ 0``) in the east-north plane of a local tangent frame at ``gps_origin``
  (lat°, lon°, alt m; default the first fix), :func:`~.ros_convert.enu_of`; ``meta["gps_origin"]``.
* ``heading``: yaw of ``orientation`` (skipped when ``orientation_covariance[0] = −1``, ROS's "no orientation"),
  ``yaw_rate`` = ``angular_velocity.z``. Noise: the median stated NavSatFix (east, north) covariance and IMU yaw
  variance, where stated.
* Time: ``stamps="header"`` (default) uses each message's ``header.stamp`` (a type without a header — ``Twist`` —
  its receive time), ``"receive"`` the bag's record time; ``meta["stamps"]`` says which each topic used. Stamps
  that step back are a :class:`DataFormatError` naming the bag, topic and message (``slamarena data info`` lists
  them without failing).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import ClassVar, Literal

import numpy as np
from pydantic import PositiveFloat

from slamarena.params import Field, Params, with_params

from ..errors import DataWarning
from ..geometry import between, interpolate_poses
from ..sequence import Gps, Heading, Increments, Noise, Scans, Sequence, Trajectory, Twist
from ..source import Layout, SourceParams
from .bag_io import TopicMessages, bag_error, bag_location, open_bag, pick_topic, read_topic
from .ros_convert import enu_of, layout_of, mount_from_tf, planar_mount, scan_arrays, yaw_of

__all__ = ["read", "load", "streams_in", "BagParams", "BagSource", "TYPES"]

#: role → the message types read for it
TYPES: dict[str, tuple[str, ...]] = {
    "scan": ("sensor_msgs/msg/LaserScan",),
    "odom": ("nav_msgs/msg/Odometry",),
    "cmd_vel": ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"),
    "gps": ("sensor_msgs/msg/NavSatFix",),
    "imu": ("sensor_msgs/msg/Imu",),
    "truth": ("nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseStamped"),
    "tf": ("tf2_msgs/msg/TFMessage",),
}


class BagParams(Params):
    """Options of the bag reader (:func:`read`)."""

    scan_topic: str | None = Field(None, description="the LaserScan topic; None: the one LaserScan topic, if any")
    odom_topic: str | None = Field(None, description="the Odometry topic; None: the one Odometry topic, if any")
    cmd_vel_topic: str | None = Field(
        None, description="the Twist/TwistStamped topic; None: the one such topic, if any"
    )
    gps_topic: str | None = Field(None, description="the NavSatFix topic; None: the one NavSatFix topic, if any")
    imu_topic: str | None = Field(None, description="the Imu topic; None: the one Imu topic, if any")
    truth_topic: str | None = Field(
        None, description="an Odometry or PoseStamped topic holding ground truth (never guessed)"
    )
    base_frame: str | None = Field(
        None, description="the robot's base frame; None: the odometry's child_frame_id, else base_link"
    )
    stamps: Literal["header", "receive"] = Field(
        "header", description="message header stamps, or the bag's receive time"
    )
    motion: Literal["auto", "odometry", "odometry_twist", "cmd_vel"] = Field(
        "auto",
        description="Sequence.motion: odometry increments, the odometry's twists, or cmd_vel (auto: odometry if any)",
    )
    max_range: PositiveFloat | None = Field(
        None, description="readings >= max_range are no return [m]; None: the largest range_max"
    )
    gps_origin: tuple[float, float, float] | None = Field(
        None, description="origin of the local east-north frame (lat deg, lon deg, alt m); None: the first fix"
    )


def _topic(reader, option: str | None, role: str, exclude: tuple[str | None, ...] = ()) -> TopicMessages | None:
    """The messages of the topic for ``role`` (named by ``option`` or found by type), None when absent."""
    topic = pick_topic(reader, option, TYPES[role], role, exclude)
    if topic is None:
        return None
    messages = read_topic(reader, topic)
    if option is not None and not len(messages):
        raise bag_error(messages.bag, topic, None, f"messages for {role}", "none")
    return messages if len(messages) else None


def _finite(messages: TopicMessages, values: np.ndarray, what: str) -> np.ndarray:
    bad = np.flatnonzero(~np.isfinite(values.reshape(len(values), -1)).all(axis=1))
    if bad.size:
        raise bag_error(messages.bag, messages.topic, int(bad[0]), f"a finite {what}", str(values[bad[0]].tolist()))
    return values


def _poses(messages: TopicMessages) -> np.ndarray:
    """(N, 3) planar poses of Odometry or PoseStamped messages."""
    out = np.empty((len(messages), 3))
    for k, m in enumerate(messages.messages):
        pose = m.pose.pose if hasattr(m.pose, "pose") else m.pose
        q = pose.orientation
        out[k] = (pose.position.x, pose.position.y, yaw_of(np.array([q.x, q.y, q.z, q.w])))
    return _finite(messages, out, "pose")


def _mount(bag, base: str, laser: str, tf: list, meta: dict) -> tuple[np.ndarray, bool]:
    """The laser's planar mounting in the base frame from the TF chain and whether it is upside down (module
    docstring); sets meta["mount_source"]."""
    meta["mount_source"] = "identity: the scans are in the base frame"
    if not laser or laser == base.lstrip("/"):
        return np.zeros(3), False
    chain = mount_from_tf(tf, base, laser)
    if chain is None:
        warnings.warn(
            f"{bag}: no tf chain from {base} to the laser frame {laser}: the laser is taken at the base", DataWarning
        )
        meta["mount_source"] = f"identity: no tf chain from {base} to {laser}"
        return np.zeros(3), False
    pose, frames = chain
    mount = planar_mount(pose)
    if mount is None:
        raise bag_error(
            bag,
            "/tf_static",
            None,
            f"a level or upside-down laser ({laser} rotated about z, or about z and by π about x, in {base})",
            str(pose[:3, :3].round(6).tolist()),
        )
    meta["mount_source"] = "tf: " + " → ".join(frames) + (" (upside down: beam angles negated)" if mount[1] else "")
    return mount


def _scans(bag, scan: TopicMessages, t: np.ndarray, odom, base: str, tf: list, params: BagParams, meta: dict) -> Scans:
    keys = [layout_of(m) for m in scan.messages]
    other = next((k for k, key in enumerate(keys) if key != keys[0]), None)
    if other is not None:
        raise bag_error(
            scan.bag,
            scan.topic,
            other,
            f"the beam layout of message 0 (beams, angle_min, angle_increment) {keys[0]}",
            str(keys[other]),
        )
    arrays = scan_arrays(scan.messages)
    laser = scan.messages[0].header.frame_id.lstrip("/")
    mount, upside_down = _mount(bag, base, laser, tf, meta)
    pose = None
    if odom is not None:
        t_odom, odom_poses = odom
        inside = (t >= t_odom[0]) & (t <= t_odom[-1])
        pose = np.full((len(t), 3), np.nan)
        if len(t_odom) > 1:
            pose[inside] = interpolate_poses(t_odom, odom_poses, t[inside])
        else:
            pose[inside] = odom_poses[0]
        meta["scans_without_odometry"] = int((~inside).sum())
    meta.update(
        laser_frame=laser,
        range_min=arrays["range_min"],
        range_max=arrays["range_max"],
        no_return_readings=arrays["no_return_readings"],
        invalid_readings=arrays["invalid_readings"],
        beam_layout={
            "beams": int(arrays["angles"].size),
            "angle_min": float(arrays["angles"][0]),
            "angle_increment": float(scan.messages[0].angle_increment),
        },
    )
    return Scans(
        t=t,
        ranges=arrays["ranges"],
        angles=-arrays["angles"] if upside_down else arrays["angles"],
        max_range=params.max_range or arrays["range_max"],
        mount=mount,
        pose=pose,
        intensities=arrays["intensities"],
    )


def _gps(fix: TopicMessages, t: np.ndarray, params: BagParams, meta: dict) -> tuple[Gps, np.ndarray | None]:
    lla = np.array([(m.latitude, m.longitude, m.altitude) for m in fix.messages], dtype=float)
    status = np.array([m.status.status for m in fix.messages])
    ok = (status >= 0) & np.isfinite(lla).all(axis=1)
    meta["gps_dropped_no_fix"] = int((~ok).sum())
    if not ok.any():
        raise bag_error(fix.bag, fix.topic, None, "a NavSatFix with a fix (status >= 0, finite)", "none")
    origin = params.gps_origin or tuple(float(v) for v in lla[ok][0])
    enu = enu_of(lla[ok, 0], lla[ok, 1], lla[ok, 2], origin)
    meta["gps_origin"] = {"lat_deg": origin[0], "lon_deg": origin[1], "alt_m": origin[2]}
    meta["gps_projection"] = "WGS-84 → ECEF → local east-north-up at gps_origin (x east, y north)"
    cov = np.array(
        [np.asarray(m.position_covariance, dtype=float).reshape(3, 3)[:2, :2] for m, k in zip(fix.messages, ok) if k]
    )
    stated = np.array([m.position_covariance_type > 0 for m, k in zip(fix.messages, ok) if k])
    return Gps(t=t[ok], xy=enu[:, :2]), (np.median(cov[stated], axis=0) if stated.any() else None)


def _heading(imu: TopicMessages, t: np.ndarray) -> tuple[Heading | None, float | None]:
    q = np.array([(m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w) for m in imu.messages])
    has = np.array([m.orientation_covariance[0] != -1.0 for m in imu.messages])
    rate = np.array([m.angular_velocity.z for m in imu.messages])
    if not has.any():
        return None, None
    var = np.array([m.orientation_covariance[8] for m in imu.messages])[has]
    return Heading(t=t[has], yaw=yaw_of(q[has]), yaw_rate=rate[has]), (
        float(np.median(var)) if np.any(var > 0) else None
    )


def _twists(messages: TopicMessages, t: np.ndarray, odometry: bool) -> Twist:
    def twist(m):
        return m.twist.twist if odometry else (m.twist if hasattr(m, "twist") else m)

    vw = np.array([(twist(m).linear.x, twist(m).angular.z) for m in messages.messages])
    return Twist.from_stamps(t, vw[:, 0], vw[:, 1])


def _motion(bag, params: BagParams, present: dict, t: dict, odom, meta: dict):
    """``(Sequence.motion, initial_pose)`` of the ``motion`` option (module docstring); sets meta["motion_source"]."""
    choice = params.motion if params.motion != "auto" else ("odometry" if odom else "cmd_vel")
    if choice in ("odometry", "odometry_twist") and odom is None:
        raise bag_error(bag, params.odom_topic, None, f"an Odometry topic for motion={choice!r}", "none")
    if choice == "odometry":
        meta["motion_source"] = f"{present['odom'].topic}: odometry poses, between consecutive messages"
        if len(odom[0]) < 2:
            return None, odom[1][0]
        return Increments(t=odom[0][1:], delta=between(odom[1][:-1], odom[1][1:])), odom[1][0]
    if choice == "odometry_twist":
        meta["motion_source"] = f"{present['odom'].topic}: odometry twists (linear.x, angular.z)"
        return _twists(present["odom"], t["odom"], odometry=True), odom[1][0]
    if "cmd_vel" not in present:
        if params.motion == "cmd_vel":
            raise bag_error(
                bag, params.cmd_vel_topic, None, "a Twist or TwistStamped topic for motion='cmd_vel'", "none"
            )
        return None, None
    meta["motion_source"] = (
        f"{present['cmd_vel'].topic}: velocity commands (linear.x, angular.z), each held to the next"
    )
    return _twists(present["cmd_vel"], t["cmd_vel"], odometry=False), None


@with_params(BagParams)
def read(path: str | Path, name: str | None = None, /, *, params: BagParams) -> Sequence:
    """A ROS bag as a :class:`Sequence` (see the module docstring)."""
    bag = bag_location(path)
    meta: dict = {"format": "ROS bag", "file": str(bag), "stamps": {}, "topics_read": {}}
    with open_bag(bag) as reader:
        meta["bag_kind"] = "ROS 2" if reader.is2 else "ROS 1"
        meta["topics"] = {c.topic: c.msgtype for c in reader.connections}
        exclude = (params.truth_topic,)
        streams = {
            "scan": _topic(reader, params.scan_topic, "scan", exclude),
            "odom": _topic(reader, params.odom_topic, "odom", exclude),
            "cmd_vel": _topic(reader, params.cmd_vel_topic, "cmd_vel", exclude),
            "gps": _topic(reader, params.gps_topic, "gps", exclude),
            "imu": _topic(reader, params.imu_topic, "imu", exclude),
            "truth": _topic(reader, params.truth_topic, "truth") if params.truth_topic else None,
        }
        tf = []
        for topic in ("/tf_static", "/tf", "tf_static", "tf"):
            if topic in meta["topics"] and meta["topics"][topic] in TYPES["tf"]:
                tf += read_topic(reader, topic).messages
    present = {role: m for role, m in streams.items() if m is not None}
    if not present:
        raise bag_error(
            bag,
            None,
            None,
            "a topic of a type read (" + ", ".join(sorted({m for v in TYPES.values() for m in v})) + ")",
            "none",
        )
    t = {}
    for role, messages in present.items():
        t[role] = messages.monotonic(params.stamps)
        meta["stamps"][messages.topic] = messages.stamp_source(params.stamps)
        meta["topics_read"][role] = messages.topic
    meta["time_source"] = f"{params.stamps} stamps as recorded in the bag (per topic: meta['stamps'])"

    odom = (t["odom"], _poses(present["odom"])) if "odom" in present else None
    motion, initial = _motion(bag, params, present, t, odom, meta)
    base = params.base_frame or (present["odom"].messages[0].child_frame_id if odom else "") or "base_link"
    meta["base_frame"] = base
    scans = _scans(bag, present["scan"], t["scan"], odom, base, tf, params, meta) if "scan" in present else None
    gps, gps_cov = _gps(present["gps"], t["gps"], params, meta) if "gps" in present else (None, None)
    heading, yaw_var = _heading(present["imu"], t["imu"]) if "imu" in present else (None, None)
    truth = Trajectory(t=t["truth"], poses=_poses(present["truth"])) if "truth" in present else None
    if odom is not None:
        meta["odometry_twist"] = np.array(
            [(m.twist.twist.linear.x, m.twist.twist.angular.z) for m in present["odom"].messages]
        )
    meta["ground_truth_kind"] = f"{present['truth'].topic} (named truth_topic)" if truth is not None else "none"
    meta["messages"] = {m.topic: len(m) for m in present.values()}
    return Sequence(
        name=name or f"bag:{bag}",
        motion=motion,
        scans=scans,
        gps=gps,
        heading=heading,
        ground_truth=truth,
        initial_pose=initial,
        noise=Noise(gps_cov=gps_cov, yaw_var=yaw_var),
        meta=meta,
    )


def streams_in(path: str | Path, options: dict) -> frozenset[str]:
    """The Sequence streams the bag at ``path`` gives with reader ``options`` (a mapping of :class:`BagParams` fields),
    from its topics' types alone (no message is read): for the experiment config's check."""
    params = BagParams.of({k: v for k, v in options.items() if k in BagParams.model_fields})
    with open_bag(path) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
    named = {"scan": params.scan_topic, "odom": params.odom_topic, "cmd_vel": params.cmd_vel_topic,
             "gps": params.gps_topic, "imu": params.imu_topic}  # fmt: skip
    have = {
        role
        for role, topic in named.items()
        if ((types.get(topic) in TYPES[role]) if topic else any(m in TYPES[role] for m in types.values()))
    }
    streams = {"scans": "scan", "gps": "gps", "heading": "imu"}
    out = {stream for stream, role in streams.items() if role in have}
    if have & {"odom", "cmd_vel"}:
        out.add("motion")
    return frozenset(out)


class BagSource(BagParams, SourceParams):
    """A ROS bag at a path and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path",)
    path: str = Field(description="a ROS 1 .bag file, a ROS 2 bag folder (sqlite3 or MCAP storage) or a .mcap file")

    def layout(self) -> Layout:
        # a ROS 2 bag folder is found by its metadata.yaml (the data roots look for files)
        is_file = Path(self.path).suffix in (".bag", ".mcap", ".yaml")
        return Layout({"bag": (self.path if is_file else f"{self.path.rstrip('/')}/metadata.yaml",)})


@with_params(BagSource)
def load(files: dict, name: str, /, *, params: BagSource) -> Sequence:
    """The family reader: role ``bag`` (a ROS 2 folder's ``metadata.yaml`` stands for its folder)."""
    return read(files["bag"], name, params=params.options(BagParams))
