"""Trajectory files of other systems (TUM, KITTI poses, EuRoC CSV, g2o vertices): hand-checked lines, round trips,
tilted poses refused."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import trajectories


@pytest.fixture
def poses(rng):
    t = np.sort(rng.uniform(0, 100, 30)).round(9)
    p = np.column_stack([rng.normal(0, 10, 30), rng.normal(0, 10, 30), rng.uniform(-np.pi, np.pi, 30)])
    return t, p


@pytest.mark.parametrize("suffix", [".tum", ".kitti", ".csv", ".g2o", ".txt"])
def test_round_trip(tmp_path, poses, suffix):
    t, p = poses
    path = tmp_path / f"traj{suffix}"
    trajectories.write(path, t, p)
    back = trajectories.read(path)
    np.testing.assert_allclose(back.poses, p, atol=1e-12)
    stamped = suffix not in (".kitti", ".g2o")  # KITTI and g2o carry no stamps: the index
    np.testing.assert_allclose(back.t, t if stamped else np.arange(len(t)), atol=1e-9)


def test_kitti_rows_are_the_3x4_matrix_row_by_row(tmp_path):
    c, s = np.cos(0.5), np.sin(0.5)
    path = tmp_path / "poses.txt"  # 12 columns: KITTI
    path.write_text(f"1 0 0 0 0 1 0 0 0 0 1 0\n{c} {-s} 0 3.5 {s} {c} 0 -2 0 0 1 0\n")
    times = tmp_path / "times.txt"
    times.write_text("0.0\n0.1\n")
    traj = trajectories.read(path, times=times)
    np.testing.assert_allclose(traj.poses, [[0, 0, 0], [3.5, -2, 0.5]], atol=1e-15)
    np.testing.assert_allclose(traj.t, [0.0, 0.1])
    trajectories.write(tmp_path / "out.kitti", traj.t, traj.poses)
    row = np.array((tmp_path / "out.kitti").read_text().splitlines()[1].split(), dtype=float)
    np.testing.assert_allclose(row, [c, -s, 0, 3.5, s, c, 0, -2, 0, 0, 1, 0], atol=1e-15)


def test_euroc_quaternion_is_w_first_and_time_in_nanoseconds(tmp_path):
    path = tmp_path / "data.csv"
    w, z = np.cos(0.25), np.sin(0.25)  # yaw 0.5
    path.write_text(
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], v_x\n"
        f"1403636579758555392,4.688,-1.786,0.783,{w},0,0,{z},0.1\n"
    )
    traj = trajectories.read(path)
    np.testing.assert_allclose(traj.poses, [[4.688, -1.786, 0.5]], atol=1e-15)
    assert traj.t[0] == pytest.approx(1403636579.758555392, abs=1e-6)
    trajectories.write(tmp_path / "out.csv", traj.t, traj.poses)
    fields = (tmp_path / "out.csv").read_text().splitlines()[1].split(",")
    assert fields[0] == "1403636579758555392"
    np.testing.assert_allclose(np.array(fields[4:8], dtype=float), [w, 0, 0, z], atol=1e-15)


def test_g2o_vertices_are_read_by_the_g2o_reader(tmp_path):
    path = tmp_path / "graph.g2o"
    path.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0.1\nEDGE_SE2 0 1 1 0 0.1 1 0 0 1 0 1\n")
    traj = trajectories.read(path)
    np.testing.assert_allclose(traj.t, [0, 1])
    np.testing.assert_allclose(traj.poses[1], [1, 0, 0.1])


@pytest.mark.parametrize(
    "name,text,line",
    [
        ("tilted.kitti", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 0.8 -0.6 0 0 0.6 0.8 0\n", 2),
        ("tilted.csv", "#t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,0,0,0.8,0.6,0,0\n", 3),
        ("bad.csv", "#t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,zero,0\n", 2),
    ],
)
def test_tilted_or_malformed_poses_are_refused_naming_the_line(tmp_path, name, text, line):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(DataFormatError, match=rf"{name}:{line}: expected"):
        trajectories.read(path)


def test_unknown_suffix_and_column_count_are_named(tmp_path):
    (tmp_path / "a.dat").write_text("0 0 0\n")
    with pytest.raises(DataFormatError, match="a.dat"):
        trajectories.read(tmp_path / "a.dat")
    (tmp_path / "a.txt").write_text("0 0 0\n")
    with pytest.raises(DataFormatError, match="8 columns"):
        trajectories.read(tmp_path / "a.txt")


def test_kitti_camera_frame_is_the_ground_plane_x_z(tmp_path):
    from scipy.spatial.transform import Rotation

    # a car 2 m forward, 1 m left, turned 0.3 rad left: in the camera frame (x right, y down, z forward) the position
    # is (−1, 0, 2) and the rotation is about the down axis by −0.3 rad
    R = Rotation.from_euler("y", -0.3).as_matrix()
    M = np.column_stack([R, [-1.0, 0.0, 2.0]])
    path = tmp_path / "00.txt"
    path.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n" + " ".join(f"{v:.17g}" for v in M.ravel()) + "\n")
    traj = trajectories.read(path, kitti_frame="camera")
    np.testing.assert_allclose(traj.poses, [[0, 0, 0], [2, 1, 0.3]], atol=1e-15)
    with pytest.raises(DataFormatError, match="00.txt:2"):  # read as x-y poses it is tilted: refused
        trajectories.read(path)
    trajectories.write(tmp_path / "back.kitti", traj.t, traj.poses, kitti_frame="camera")
    np.testing.assert_allclose(np.loadtxt(tmp_path / "back.kitti")[1], M.ravel(), atol=1e-15)


def test_a_small_tilt_is_projected_when_allowed(tmp_path):
    from scipy.spatial.transform import Rotation

    R = Rotation.from_euler("ZYX", [0.7, 0.01, -0.02]).as_matrix()  # yaw 0.7, pitch 0.01, roll −0.02 (z up)
    path = tmp_path / "pitched.kitti"
    path.write_text(" ".join(f"{v:.17g}" for v in np.column_stack([R, [1.0, 2.0, 0.3]]).ravel()) + "\n")
    with pytest.raises(DataFormatError, match=r"pitched.kitti:1: expected a planar pose \(tilt"):
        trajectories.read(path)
    traj = trajectories.read(path, max_tilt=0.05)
    np.testing.assert_allclose(traj.poses, [[1.0, 2.0, 0.7]], atol=1e-12)
