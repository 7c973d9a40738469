"""The camera readers (KITTI odometry layout, the VAMR checkerboard) against hand-checked lines of the staged files."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from checks import load_staged, staged

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import kitti_odometry, vamr
from slamarena.datasets.sequence import Camera

pytestmark = pytest.mark.realdata


@pytest.fixture(scope="module")
def kitti():
    return load_staged("kitti:00")


@pytest.fixture(scope="module")
def board():
    return load_staged("vamr:checkerboard")


def test_kitti_frames_times_calibration_and_poses(kitti):
    cam = kitti.camera
    assert len(cam) == 200 and cam.stereo.sum() == 100 and cam.stereo[:100].all()
    assert (cam.width, cam.height) == (1241, 376)
    # calib.txt: P0 fx = fy = 718.856, cx 607.1928, cy 185.2157; P1[0, 3] = -386.1448 = -fx b
    np.testing.assert_array_equal(cam.K, [[718.856, 0, 607.1928], [0, 718.856, 185.2157], [0, 0, 1]])
    assert cam.baseline == pytest.approx(386.1448 / 718.856, abs=1e-12)
    # times.txt lines 2 and 200
    assert cam.t[1] == 1.037359e-01 and cam.t[199] == 2.063096e01
    # poses/00.txt line 2 ([R | t] row-major) and line 200
    assert cam.ground_truth[1, 0, :] == pytest.approx([9.999978e-01, 5.272628e-04, -2.066935e-03, -4.690294e-02])
    assert cam.ground_truth[1, 2, 3] == 8.586941e-01
    assert cam.ground_truth[199, :3, 3] == pytest.approx([5.295984e01, -5.197886e00, 8.959271e01])
    assert kitti.meta["time_lines_unused"] == 4541 - 200
    assert cam.left[7].endswith("image_0/000007.png") and cam.right[99].endswith("image_1/000099.png")
    assert cam.right[100] == ""


def test_kitti_images_are_read_on_demand(kitti):
    cam = kitti.camera
    left, right = cam.image(0), cam.image(0, "right")
    assert left.shape == (376, 1241) and left.dtype == np.uint8 and right.shape == left.shape
    with pytest.raises(KeyError, match="no right image"):
        cam.image(150, "right")
    assert len(cam.select(slice(10, 20))) == 10 and cam.select(slice(10, 20)).left[0] == cam.left[10]


def test_kitti_frames_option_and_bad_files(tmp_path):
    calib = staged("kitti_odometry/sequences/00/calib.txt")
    seq = tmp_path / "sequences" / "07"
    (seq / "image_0").mkdir(parents=True)
    for k in range(3):
        shutil.copy(calib.parent / "image_0" / f"{k:06d}.png", seq / "image_0")
    shutil.copy(calib, seq)
    (seq / "times.txt").write_text("0.0\n0.1\n0.2\n0.3\n")
    loaded = kitti_odometry.read(
        {"first_image": seq / "image_0/000000.png", "calib": seq / "calib.txt", "times": seq / "times.txt"},
        "k",
        params=kitti_odometry.KittiSource(path=str(seq)),
    )
    assert len(loaded.camera) == 3 and loaded.camera.right is None and loaded.camera.ground_truth is None
    (seq / "times.txt").write_text("0.0\n0.2\n0.1\n")
    with pytest.raises(DataFormatError, match=r"times.txt:3: expected non-decreasing time"):
        kitti_odometry.read(
            {"first_image": seq / "image_0/000000.png", "calib": seq / "calib.txt", "times": seq / "times.txt"},
            "k",
            params=kitti_odometry.KittiSource(path=str(seq)),
        )
    (seq / "calib.txt").write_text("P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 -0.5 0 1 0 0 0 0 1\n")
    with pytest.raises(DataFormatError, match=r"calib.txt:2: expected 12 numeric fields"):
        kitti_odometry.read_calib(seq / "calib.txt")
    poses = tmp_path / "poses.txt"
    poses.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 1 0 0 0 0 1 0\n")
    with pytest.raises(DataFormatError, match=r"poses.txt:2: expected a finite pose with a rotation matrix"):
        kitti_odometry.read_poses(poses, 2)
    with pytest.raises(DataFormatError, match=r"poses.txt:2: expected 3 poses"):
        kitti_odometry.read_poses(poses, 3)


def test_checkerboard_frames_intrinsics_distortion_and_poses(board):
    cam = board.camera
    assert len(cam) == 300 and (cam.width, cam.height) == (752, 480) and cam.right is None
    assert cam.K[0, 0] == 420.506712 and cam.K[1, 2] == 250.336787
    assert cam.distortion_model == "radial_pixels" and cam.distortion.tolist() == [-1.6774e-06, 2.5847e-12]
    # poses.txt line 300: ω = (-0.4628, -0.1505, 0.0948), t = (-0.1390, -0.2343, 0.4130) of T_cam←world
    omega = np.array([-0.462753739888, -0.15050699816, 0.0948111490831])
    t = np.array([-0.139002450602, -0.234346937988, 0.41300320844])
    import cv2

    R = cv2.Rodrigues(omega)[0]  # OpenCV as the oracle of the reader's Rodrigues formula
    T_world_cam = cam.ground_truth[299]
    np.testing.assert_allclose(T_world_cam[:3, :3], R.T, atol=1e-12)
    np.testing.assert_allclose(T_world_cam[:3, 3], -R.T @ t, atol=1e-12)
    assert cam.image(299).shape == (480, 752)
    assert vamr.board_corners()[10].tolist() == [0.04, 0.04, 0.0]


def test_camera_stream_rejects_bad_fields():
    with pytest.raises(ValueError, match="baseline"):
        Camera(t=[0, 1], left=["a", "b"], K=np.eye(3), right=["c", ""])
    with pytest.raises(ValueError, match="distortion"):
        Camera(t=[0], left=["a"], K=np.eye(3), distortion=[1.0], distortion_model="radial_pixels")
    with pytest.raises(ValueError, match="ground_truth has non-finite"):
        Camera(t=[0], left=["a"], K=np.eye(3), ground_truth=np.full((1, 4, 4), np.nan))
    with pytest.raises(DataFormatError, match="missing.png: expected an image OpenCV can read"):
        Camera(t=[0], left=["missing.png"], K=np.eye(3)).image(0)


def test_checkerboard_bad_files_name_file_and_line(tmp_path):
    source = staged("vamr_checkerboard/K.txt").parent
    (tmp_path / "images").mkdir()
    for k in (1, 2):
        shutil.copy(source / "images" / f"img_{k:04d}.jpg", tmp_path / "images")
    for name in ("K.txt", "D.txt", "poses.txt"):
        shutil.copy(source / name, tmp_path)
    files = {"first_image": tmp_path / "images/img_0001.jpg", **{n[0]: tmp_path / f"{n}.txt" for n in ("K", "D")}}
    files["poses"] = tmp_path / "poses.txt"
    params = vamr.VamrSource(path=str(tmp_path))
    assert len(vamr.read(files, "v", params=params).camera) == 2
    lines = (source / "poses.txt").read_text().splitlines()
    (tmp_path / "poses.txt").write_text(lines[0] + "\n" + lines[1].rsplit(" ", 1)[0] + "\n")
    with pytest.raises(DataFormatError, match=r"poses.txt:2: expected 6 numeric fields"):
        vamr.read(files, "v", params=params)
    (tmp_path / "poses.txt").write_text(lines[0] + "\n")
    with pytest.raises(DataFormatError, match=r"poses.txt:1: expected 2 poses"):
        vamr.read(files, "v", params=params)
    (tmp_path / "poses.txt").write_text("\n".join(lines[:2]) + "\n")
    (tmp_path / "K.txt").write_text("420 0 355\n0 420 250\n0 1 1\n")
    with pytest.raises(DataFormatError, match=r"K.txt:3: expected 3 rows of an upper-triangular K"):
        vamr.read(files, "v", params=params)


def test_kitti_first_frame_option_reads_a_later_segment():
    whole = load_staged("kitti:00", frames=30).camera
    later = load_staged("kitti:00", first=15, frames=10)
    cam = later.camera
    assert len(cam) == 10 and later.meta["first_frame"] == 15 and later.meta["time_lines_unused"] == 4541 - 10
    np.testing.assert_array_equal(cam.t, whole.t[15:25])
    np.testing.assert_array_equal(cam.ground_truth, whole.ground_truth[15:25])  # still T_0←k of frame 0
    assert cam.left[0].endswith("000015.png") and cam.right[0].endswith("000015.png")
    with pytest.raises(DataFormatError, match="two or more images from image 199"):
        load_staged("kitti:00", first=199)
