"""The ROS bag reader on bags the tests write (ROS 1, ROS 2 sqlite3, ROS 2 MCAP, bare MCAP), bad bags, and the
staged ACES bag against the CARMEN reader."""

from __future__ import annotations

import re

import numpy as np
import pytest
from bags import GPS_ORIGIN, MOUNT, MOUNT_LINKS, RECEIVE_LAG, robot_bag
from checks import load_staged, staged

from slamarena import datasets
from slamarena.datasets import DataFormatError
from slamarena.datasets.formats.bag_write import BagWriter
from slamarena.datasets.formats.ros_convert import WGS84_A, WGS84_F
from slamarena.datasets.formats.ros_messages import message
from slamarena.datasets.geometry import between, wrap_angle

KINDS = [("run.bag", "sqlite3"), ("run", "sqlite3"), ("run", "mcap"), ("run.mcap", "mcap")]


@pytest.fixture(params=KINDS, ids=["ros1", "ros2-sqlite3", "ros2-mcap", "bare-mcap"])
def written(request, tmp_path):
    name, storage = request.param
    path = tmp_path / name
    return path, robot_bag(path, storage)


def test_every_stream_is_read_as_written(written):
    path, w = written
    s = datasets.load(f"bag:{path}", truth_topic="/truth")
    # scans: beam layout, masks (+inf and > range_max → no return at range_max; NaN and < range_min → NaN), intensities
    assert np.allclose(s.scans.angles, -1.0 + 0.25 * np.arange(8))
    assert s.scans.max_range == 10.0
    expected = w["ranges"].copy()
    expected[0, 1] = expected[3, 4] = 10.0
    expected[1, 2] = expected[2, 3] = np.nan
    np.testing.assert_array_equal(s.scans.ranges, expected)
    np.testing.assert_array_equal(s.scans.intensities, w["intensities"])
    assert s.meta["no_return_readings"] == 2 and s.meta["invalid_readings"] == 2
    np.testing.assert_allclose(s.scans.t, w["t_scan"])
    # the laser mounting: a two-link TF chain with non-identity links, composed
    np.testing.assert_allclose(s.scans.mount, MOUNT, atol=1e-9)
    assert s.meta["mount_source"] == "tf: base_link → laser_mount → laser"
    # odometry: every other odometry message is at a scan stamp; increments and the initial pose
    np.testing.assert_allclose(s.scans.pose, w["odom"][1::2], atol=1e-9)
    np.testing.assert_allclose(s.motion.delta, between(w["odom"][:-1], w["odom"][1:]), atol=1e-12)
    np.testing.assert_allclose(s.initial_pose, w["odom"][0], atol=1e-12)
    np.testing.assert_allclose(s.meta["odometry_twist"], w["twist"])
    # GPS in the local east-north frame at the first fix: north = meridian radius × Δφ, east = N cos φ × Δλ
    phi = np.radians(GPS_ORIGIN[0])
    e2 = WGS84_F * (2 - WGS84_F)
    M = WGS84_A * (1 - e2) / (1 - e2 * np.sin(phi) ** 2) ** 1.5 + GPS_ORIGIN[2]
    N = WGS84_A / np.sqrt(1 - e2 * np.sin(phi) ** 2) + GPS_ORIGIN[2]
    np.testing.assert_allclose(s.gps.xy[:, 1], M * np.radians(w["d_lat"]), atol=1e-4)
    np.testing.assert_allclose(s.gps.xy[:, 0], N * np.cos(phi) * np.radians(w["d_lon"]), atol=1e-4)
    assert s.meta["gps_origin"] == {"lat_deg": 48.0, "lon_deg": 11.0, "alt_m": 500.0}
    np.testing.assert_allclose(s.noise.gps_cov, np.diag([4.0, 9.0]))
    # IMU: yaw (wrapped) and yaw rate, the stated yaw variance
    np.testing.assert_allclose(s.heading.yaw, wrap_angle(w["imu_yaw"]), atol=1e-12)
    np.testing.assert_allclose(s.heading.yaw_rate, w["imu_rate"])
    assert s.noise.yaw_var == pytest.approx(2e-3)
    # ground truth only when named
    np.testing.assert_allclose(s.ground_truth.poses, w["truth"], atol=1e-12)
    # stamps: headers by default, the unstamped Twist by its receive time; the source recorded
    assert s.meta["stamps"] == {t: "header" for t in ("/scan", "/odom", "/gps", "/imu", "/truth")} | {
        "/cmd_vel": "receive"
    }
    received = datasets.load(f"bag:{path}", stamps="receive")
    np.testing.assert_allclose(received.scans.t, w["t_scan"] + RECEIVE_LAG, atol=1e-9)
    assert set(received.meta["stamps"].values()) == {"receive"}
    assert datasets.load(f"bag:{path}").ground_truth is None


def test_cmd_vel_and_odometry_twist_as_motion(tmp_path):
    w = robot_bag(tmp_path / "twist.bag", cmd_vel="Twist")
    s = datasets.load(f"bag:{tmp_path / 'twist.bag'}", motion="cmd_vel")
    np.testing.assert_allclose(np.column_stack([s.motion.v, s.motion.omega]), w["cmd"])
    np.testing.assert_allclose(s.motion.t, w["t_cmd"] + RECEIVE_LAG)  # an unstamped Twist: its receive time
    np.testing.assert_allclose(s.motion.dt[:-1], np.diff(w["t_cmd"]))
    w = robot_bag(tmp_path / "stamped", cmd_vel="TwistStamped")
    s = datasets.load(f"bag:{tmp_path / 'stamped'}", motion="cmd_vel")
    np.testing.assert_allclose(s.motion.t, w["t_cmd"])
    np.testing.assert_allclose(s.motion.v, w["cmd"][:, 0])
    s = datasets.load(f"bag:{tmp_path / 'stamped'}", motion="odometry_twist")
    np.testing.assert_allclose(np.column_stack([s.motion.v, s.motion.omega]), w["twist"])


def test_a_folder_is_named_by_itself_or_its_metadata(tmp_path):
    robot_bag(tmp_path / "run")
    a = datasets.load(f"bag:{tmp_path / 'run'}")
    b = datasets.load(f"bag:{tmp_path / 'run' / 'metadata.yaml'}")
    np.testing.assert_array_equal(a.scans.ranges, b.scans.ranges)


def _fails(path, match, **params):
    with pytest.raises(DataFormatError, match=match) as info:
        datasets.load(f"bag:{path}", **params)
    assert str(path) in str(info.value)
    return str(info.value)


@pytest.mark.parametrize("name,storage,damaged", [("t.bag", "sqlite3", "t.bag"), ("t.mcap", "mcap", "t.mcap"),
                                                  ("t", "sqlite3", "t/t.db3")])  # fmt: skip
def test_a_truncated_bag_is_named(tmp_path, name, storage, damaged):
    robot_bag(tmp_path / name, storage)
    f = tmp_path / damaged
    f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    _fails(tmp_path / name, "a readable ROS bag")


def _two_topic_bag(path, storage="sqlite3", n=12):
    """/a and /b alternating (a0 b0 a1 b1 …), each a String whose text marks it; returns the write order."""
    order = []
    with BagWriter(path, storage=storage) as w:
        for k in range(n):
            for topic in ("/a", "/b"):
                w.write(topic, 10.0 + k, message(w.typestore, "std_msgs/msg/String", data=f"<{topic}:{k:04d}>" * 40))
                order.append((topic, k))
    return order


@pytest.mark.parametrize("name", ["cut.bag", "cut.mcap"])
@pytest.mark.parametrize("topic,k", [("/b", 3), ("/a", 9)])
def test_a_bag_cut_inside_a_message_names_that_message(tmp_path, name, topic, k):
    path = tmp_path / name
    order = _two_topic_bag(path)
    data = path.read_bytes()
    inside = data.index(f"<{topic}:{k:04d}>".encode()) + 100  # the file ends in the middle of that message's text
    path.write_bytes(data[:inside])
    text = _fails(path, rf"{path}, topic {topic}, message {k}: expected a readable ROS bag")
    assert f"({order.index((topic, k))} messages intact before the damage)" in text


def test_a_bag_cut_between_its_pages_names_the_last_message_read(tmp_path):
    order = _two_topic_bag(tmp_path / "cut", n=200)
    db = tmp_path / "cut" / "cut.db3"
    db.write_bytes(db.read_bytes()[: int(db.stat().st_size * 0.9)])
    text = _fails(tmp_path / "cut", "expected a readable ROS bag")
    intact = int(re.search(r"\((\d+) messages intact", text).group(1))
    assert 0 < intact < len(order)
    topic, k = order[intact - 1]  # sqlite keeps the rows in the order written
    assert f"{tmp_path / 'cut'}, topic {topic}, after message {k}:" in text


def _compressed_writer(path, compression):
    """A rosbags writer whose chunks are compressed: ROS 1 bz2 or lz4 (4 KiB chunks, as a recorder makes many), or a
    ROS 2 MCAP bag with zstd chunks (rosbags closes a chunk at 1 MiB)."""
    if compression == "zstd":
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

        w = Writer(path, version=8, storage_plugin=StoragePlugin.MCAP)
        w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        return w
    from rosbags.rosbag1 import Writer

    w = Writer(path)
    w.chunk_threshold = 4096
    w.set_compression(getattr(Writer.CompressionFormat, compression))
    return w


@pytest.mark.parametrize("compression,name,n,size", [("BZ2", "z.bag", 300, 64), ("LZ4", "z.bag", 300, 64),
                                                      ("zstd", "z", 1200, 700)])  # fmt: skip
def test_a_compressed_bag_cut_in_a_chunk_names_a_message_in_write_order(tmp_path, compression, name, n, size):
    from rosbags.typesys import Stores, get_typestore

    ros1 = name.endswith(".bag")
    ts, path, order = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE), tmp_path / name, []
    noise = np.random.default_rng(0).bytes(n * 2 * size).hex()  # incompressible text: the chunks fill the file
    with _compressed_writer(path, compression) as w:
        conns = {t: w.add_connection(t, "std_msgs/msg/String", typestore=ts) for t in ("/a", "/b")}
        for k in range(n):
            for topic in conns:
                text = message(
                    ts, "std_msgs/msg/String", data=f"{topic}:{k}:" + noise[len(order) * 2 * size :][: 2 * size]
                )
                serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
                w.write(conns[topic], (10 + k) * 10**9, serialize(text, "std_msgs/msg/String"))
                order.append((topic, k))
    f = path if ros1 else next(path.glob("*.mcap"))
    f.write_bytes(f.read_bytes()[: int(f.stat().st_size * 0.5)])
    text = _fails(path, "expected a readable ROS bag")
    intact = int(re.search(r"\((\d+) messages intact", text).group(1))
    assert 0 < intact < len(order)
    inside, after = order[intact], order[intact - 1]
    assert f"topic {inside[0]}, message {inside[1]}:" in text or f"topic {after[0]}, after message {after[1]}:" in text


def test_missing_and_mistyped_topics_are_named(tmp_path):
    path = tmp_path / "m.bag"
    robot_bag(path)
    assert "topic /nope" in _fails(path, "a topic /nope for scan", scan_topic="/nope")
    assert "sensor_msgs/msg/LaserScan" in _fails(path, "topic /odom: expected a message of type", scan_topic="/odom")
    _fails(path, "an Odometry topic", motion="odometry", odom_topic=None, scan_topic="/scan", truth_topic="/odom")


def test_stamps_stepping_back_name_topic_and_message(tmp_path):
    path = tmp_path / "back"
    robot_bag(path, scan_stamps=[10.0, 10.1, 10.05, 10.3, 10.4])
    _fails(path, r"topic /scan, message 2: expected non-decreasing header stamps")


def test_a_damaged_message_names_topic_and_index(tmp_path):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    from slamarena.datasets.formats.ros_messages import header, message

    ts = get_typestore(Stores.ROS2_HUMBLE)
    path = tmp_path / "damaged"
    with Writer(path, version=8) as w:
        conn = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        for k in range(3):
            scan = message(ts, "sensor_msgs/msg/LaserScan", header=header(k, "laser"), ranges=[1.0], range_max=5.0)
            data = ts.serialize_cdr(scan, scan.__msgtype__)
            w.write(conn, k * 10**9, data if k != 1 else data[:9])
    _fails(path, "topic /scan, message 1: expected a sensor_msgs/msg/LaserScan message")


def test_a_tf_chain_with_a_3d_link_composes_in_3d(tmp_path):
    # base → mount: 0.5 m up and pitched by 30°, mount → laser: pitched back by −30°: a level laser, the chain in 3D
    from scipy.spatial.transform import Rotation

    up = np.eye(4)
    up[:3, :3] = Rotation.from_euler("y", 30, degrees=True).as_matrix()
    up[:3, 3] = (0.1, 0.2, 0.5)
    back = np.eye(4)
    back[:3, :3] = Rotation.from_euler("y", -30, degrees=True).as_matrix() @ Rotation.from_euler("z", 0.4).as_matrix()
    back[:3, 3] = (0.3, 0.0, 0.0)
    robot_bag(tmp_path / "tilt.bag", mount_links=(up, back))
    expected = up @ back
    s = datasets.load(f"bag:{tmp_path / 'tilt.bag'}")
    np.testing.assert_allclose(s.scans.mount, [expected[0, 3], expected[1, 3], 0.4], atol=1e-9)
    assert abs(expected[0, 3] - 0.1 - 0.3 * np.cos(np.radians(30))) < 1e-12  # the 30° pitch shortens the x offset


def test_a_tilted_laser_is_refused_and_a_missing_chain_warned(tmp_path):
    from scipy.spatial.transform import Rotation

    tilted = np.eye(4)
    tilted[:3, :3] = Rotation.from_euler("x", 10, degrees=True).as_matrix()
    robot_bag(tmp_path / "tilted.bag", mount_links=(tilted, np.zeros(3)))
    _fails(tmp_path / "tilted.bag", "a level or upside-down laser")
    robot_bag(tmp_path / "none.bag", mount_links=None)
    with pytest.warns(datasets.DataWarning, match="no tf chain from base_link to the laser frame laser"):
        s = datasets.load(f"bag:{tmp_path / 'none.bag'}")
    np.testing.assert_array_equal(s.scans.mount, 0.0)


def test_an_upside_down_laser_sees_the_same_points_in_the_base_frame(tmp_path):
    from scipy.spatial.transform import Rotation

    from slamarena.datasets.geometry import transform_points

    flipped = np.eye(4)
    flipped[:3, :3] = Rotation.from_euler("x", np.pi).as_matrix()
    flipped[:3, 3] = (0.05, -0.02, 0.1)
    robot_bag(tmp_path / "flip.bag", mount_links=(MOUNT_LINKS[0], flipped))
    s = datasets.load(f"bag:{tmp_path / 'flip.bag'}")
    assert s.meta["mount_source"].endswith("(upside down: beam angles negated)")
    # oracle: every beam's end point through the 3D chain, against the Sequence's planar mount and angles
    base_mount = np.eye(4)
    base_mount[:3, :3] = Rotation.from_euler("z", MOUNT_LINKS[0][2]).as_matrix()
    base_mount[:2, 3] = MOUNT_LINKS[0][:2]
    r, a = s.scans.beams(0)
    ok = np.isfinite(r)
    a_laser = -1.0 + 0.25 * np.arange(8)
    laser_points = np.column_stack([r * np.cos(a_laser), r * np.sin(a_laser), np.zeros(8), np.ones(8)])[ok]
    expected = (base_mount @ flipped @ laser_points.T).T[:, :2]
    got = transform_points(s.scans.mount, np.column_stack([r * np.cos(a), r * np.sin(a)])[ok])
    np.testing.assert_allclose(got, expected, atol=1e-9)


def test_a_second_beam_layout_is_named(tmp_path):
    robot_bag(tmp_path / "layout.bag", angle_min=[-1.0, -1.0, -1.0, -0.9, -1.0])
    _fails(tmp_path / "layout.bag", "topic /scan, message 3: expected the beam layout of message 0")


@pytest.mark.realdata
def test_staged_aces_bag_equals_the_carmen_log_message_for_message():
    bag = staged("ros_bags/aces.clf2bag.bag")
    b = datasets.load(f"bag:{bag}")
    c = load_staged("carmen:aces")
    assert len(b.scans) == len(c.scans) == 7374
    np.testing.assert_array_equal(b.scans.ranges, c.scans.ranges)  # bit-identical float32 ranges
    np.testing.assert_allclose(b.scans.pose, c.scans.pose, atol=1e-12)  # the odometry pose of each scan
    np.testing.assert_allclose(b.initial_pose, c.scans.pose[0], atol=1e-12)
    assert b.scans.max_range == c.scans.max_range == 50.0
    # the beam layouts differ as SOURCE.md says: π/179 (both ends) in the bag, π/180 in the CARMEN log
    np.testing.assert_allclose(np.diff(b.scans.angles), np.float32(np.pi / 179), rtol=1e-6)
    np.testing.assert_allclose(np.diff(c.scans.angles), np.pi / 180)
    # the stamps are the bag's synthetic ones, recorded as header stamps
    np.testing.assert_allclose(b.scans.t, 1e9 + 0.1 * np.arange(7374), atol=1e-6)
    assert b.meta["stamps"] == {"/scan": "header", "/odom": "header"}
    np.testing.assert_allclose(b.scans.mount, 0.0)


def test_an_empty_file_and_a_bag_without_a_topic_read_are_errors(tmp_path):
    from slamarena.datasets.formats.bag_write import BagWriter
    from slamarena.datasets.formats.ros_messages import message

    (tmp_path / "empty.bag").write_bytes(b"")
    _fails(tmp_path / "empty.bag", "a readable ROS bag")
    with BagWriter(tmp_path / "other.mcap") as w:
        w.write("/chatter", 1.0, message(w.typestore, "std_msgs/msg/String", data="hello"))
    _fails(tmp_path / "other.mcap", "a topic of a type read")


def test_header_stamps_all_zero_fall_back_to_receive_time(tmp_path):
    from slamarena.datasets.formats.bag_write import BagWriter
    from slamarena.datasets.formats.ros_messages import header, message

    with BagWriter(tmp_path / "zero.mcap") as w:
        for k in range(4):
            body = {"linear": {"x": 0.5}, "angular": {"z": 0.1}}
            msg = message(w.typestore, "geometry_msgs/msg/TwistStamped", header=header(0.0, "base_link"), twist=body)
            w.write("/cmd_vel", 5.0 + 0.02 * k, msg)
    s = datasets.load(f"bag:{tmp_path / 'zero.mcap'}")
    np.testing.assert_allclose(s.motion.t, 5.0 + 0.02 * np.arange(4))
    assert s.meta["stamps"] == {"/cmd_vel": "receive"}


def test_a_topic_of_an_unknown_type_is_listed_and_refused_when_named(tmp_path):
    from rosbags.typesys import get_types_from_msg

    from slamarena.datasets.formats.bag_write import BagWriter
    from slamarena.datasets.formats.ros_messages import header, message

    path = tmp_path / "custom.mcap"
    with BagWriter(path) as w:
        w.typestore.register(get_types_from_msg("uint8[] data\nfloat64 quality", "my_msgs/msg/Blob"))
        for k in range(3):
            w.write("/blob", 1.0 + k, message(w.typestore, "my_msgs/msg/Blob", data=[1, 2, 3], quality=0.5))
            scan = message(w.typestore, "sensor_msgs/msg/LaserScan", header=header(1.0 + k, "base_link"),
                           angle_increment=0.1, range_max=5.0, ranges=[1.0, 2.0])  # fmt: skip
            w.write("/scan", 1.0 + k, scan)
    s = datasets.load(f"bag:{path}")
    assert s.meta["topics"]["/blob"] == "my_msgs/msg/Blob" and len(s.scans) == 3
    _fails(path, "topic /blob: expected a message of type sensor_msgs/msg/LaserScan", scan_topic="/blob")
