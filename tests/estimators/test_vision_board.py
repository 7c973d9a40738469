"""The checkerboard goal of issue 32: PnP poses from the board's corners within 1 cm / 0.5° of the staged poses on
at least 95 % of frames (all 300 staged frames; nothing here was tuned on them: the RANSAC threshold is the PnP
default, 2 px). Measured: 300/300, camera centre error median 1.2 mm (max 3.2 mm), rotation median 0.19° (max 0.45°)."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged

from slamarena.datasets.formats.vamr import BOARD, board_corners
from slamarena.estimators.vision.board_pose import board_poses
from slamarena.estimators.vision.lie import rotation_angle

pytestmark = pytest.mark.realdata


@pytest.mark.parametrize("nonminimal", ["epnp", "dls"])
def test_board_poses_within_1cm_and_half_a_degree_on_95_percent_of_frames(nonminimal):
    """P3P RANSAC then LM (EPnP refuses the planar board), or P3P RANSAC, DLS on the inliers, then LM."""
    camera = load_staged("vamr:checkerboard").camera
    poses = board_poses(camera, board_corners(), BOARD[:2], nonminimal=nonminimal)
    truth = np.linalg.inv(camera.ground_truth)  # T_cam←world
    centre = -np.einsum("nji,nj->ni", poses.R, poses.t)
    centre_true = -np.einsum("nji,nj->ni", truth[:, :3, :3], truth[:, :3, 3])
    position_error = np.linalg.norm(centre - centre_true, axis=1)
    angle_error = np.degrees(rotation_angle(np.einsum("nji,njk->nik", poses.R, truth[:, :3, :3])))
    within = poses.found & (position_error < 0.01) & (angle_error < 0.5)
    assert within.mean() >= 0.95, (within.mean(), np.nanmax(position_error), np.nanmax(angle_error))
    assert np.nanmedian(poses.rms) < 0.5  # the corners agree with the pinhole + radial model to sub-pixel
