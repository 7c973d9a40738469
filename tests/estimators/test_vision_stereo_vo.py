"""Stereo VO on the staged KITTI 00 frames (parameters set a priori: StereoVOParams' defaults).

Measured on frames 0–99 (84 m; `slamarena run kitti_vo`, research/notebook/2026-11-28-vision-pipeline.md): ATE
0.53 % of the path after SE(3) alignment, KITTI t_rel 2.68 % (2.45 % with the windowed BA) over segments of 10, 20,
40, 80 m, end-point drift 3.5 % (3.4 %), 15.6 (12.8) frames per CPU second; the OpenCV-only baseline in the same
pipeline 2.92 % and 3.5 %. The default tests run the first 30 frames; the slow one all 100."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged

from slamarena.estimators.vision.mono_vo import mono_vo
from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_points, stereo_vo
from slamarena.experiments.metrics.trajectory3d import ate_3d, kitti_relative_error

pytestmark = pytest.mark.realdata


def test_stereo_points_have_kitti_depths_and_reproject_to_the_left_pixels():
    camera = load_staged("kitti:00", frames=2).camera
    u, u_right, X, d = stereo_points(camera, 0, StereoVOParams())
    # z = fx b / d, up to the DLT spreading a row difference (≤ 1 px) between the two rays
    np.testing.assert_allclose(camera.K[0, 0] * camera.baseline / (u[:, 0] - u_right), X[:, 2], rtol=1e-4)
    assert len(u) > 300 and d.shape == (len(u), 32)
    np.testing.assert_allclose(X[:, :2] / X[:, 2:] * np.diag(camera.K)[:2] + camera.K[:2, 2], u, atol=1.0)
    assert np.median(X[:, 2]) > 5 and X[:, 2].max() < camera.K[0, 0] * camera.baseline / 2.0 + 1e-6


def test_stereo_vo_tracks_the_first_30_frames():
    camera = load_staged("kitti:00", frames=30).camera
    result = stereo_vo(camera)
    assert result.lost == 0 and result.inliers[1:].min() >= 40
    assert ate_3d(result.poses, camera.ground_truth, "se3")["rmse_percent_of_path"] < 3.0  # measured 0.47 m of 25 m


def test_the_opencv_baseline_and_ours_agree_on_the_first_30_frames():
    camera = load_staged("kitti:00", frames=30).camera
    ours = stereo_vo(camera)
    theirs = stereo_vo(camera, StereoVOParams(tracking={"geometry": "opencv"}))
    assert theirs.lost == 0
    gap = np.linalg.norm(ours.poses[:, :3, 3] - theirs.poses[:, :3, 3], axis=1)
    assert gap.max() < 0.05 * np.linalg.norm(camera.ground_truth[-1, :3, 3])


def test_mono_vo_tracks_the_first_60_frames_up_to_scale():
    camera = load_staged("kitti:00", frames=60).camera
    result = mono_vo(camera)
    assert result.lost == 0 and len(result.keyframes) > 5
    assert ate_3d(result.poses, camera.ground_truth, "sim3")["rmse_percent_of_path"] < 5.0


def test_stereo_vo_with_windowed_bundle_adjustment_runs_its_windows():
    camera = load_staged("kitti:00", frames=20).camera
    result = stereo_vo(camera, StereoVOParams(window=5))
    assert result.meta["ba_failures"] == [] and result.meta["ba_runs"] == len(result.keyframes) - 1
    assert ate_3d(result.poses, camera.ground_truth, "se3")["rmse_percent_of_path"] < 3.0


@pytest.mark.slow
def test_stereo_vo_on_frames_0_to_99():
    camera = load_staged("kitti:00", frames=100).camera
    result = stereo_vo(camera)
    assert ate_3d(result.poses, camera.ground_truth, "se3")["rmse_percent_of_path"] < 1.0
    assert kitti_relative_error(result.poses, camera.ground_truth, [10, 20, 40, 80], step=1)["t_rel_percent"] < 3.0
