"""The VO pipelines behind the estimator protocol: the top view of a 3-D trajectory, the Estimate they return."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.estimate import Estimate
from slamarena.estimators import REGISTRY, create
from slamarena.estimators.vision.estimators import top_view
from slamarena.estimators.vision.lie import so3_exp


def test_top_view_of_a_camera_turning_right_while_moving_right():
    """Camera axes x right, y down, z forward; top view x forward, y left, θ counter-clockwise from above. A camera
    yawed by a about its y axis (down) looks right for a > 0: its top-view heading is −a."""
    a = 0.3
    T = np.eye(4)
    T[:3, :3] = so3_exp(np.array([0.0, a, 0.0]))
    T[:3, 3] = [2.0, -1.65, 5.0]  # 2 m right, 1.65 m up, 5 m ahead
    np.testing.assert_allclose(top_view(T[None]), [[5.0, -2.0, -a]], atol=1e-12)
    forward = T[:3, :3] @ [0.0, 0.0, 1.0]
    assert forward[0] > 0  # it does look right


def test_estimate_keeps_its_3d_poses_through_a_file(tmp_path):
    poses = np.tile(np.eye(4), (3, 1, 1))
    poses[:, 2, 3] = [0.0, 1.0, 2.0]
    estimate = Estimate(method="vo", t=[0.0, 0.1, 0.2], poses=top_view(poses), poses_3d=poses)
    estimate.save(tmp_path / "e.npz")
    np.testing.assert_array_equal(Estimate.load(tmp_path / "e.npz").poses_3d, poses)
    with pytest.raises(ValueError, match="3-D poses"):
        Estimate(method="vo", t=[0.0, 0.1], poses=np.zeros((2, 3)), poses_3d=poses)


def test_vo_methods_are_registered_and_refuse_a_sequence_without_camera():
    from slamarena.datasets.sequence import Sequence

    assert {"stereo_vo", "mono_vo"} <= set(REGISTRY)
    for name in ("stereo_vo", "mono_vo"):
        with pytest.raises(ValueError, match="camera"):
            create(name).run(Sequence(name="none"))
    with pytest.raises(ValueError):
        create("stereo_vo", window=-1)


@pytest.mark.realdata
def test_stereo_vo_estimate_on_the_first_frames():
    from checks import load_staged

    data = load_staged("kitti:00", frames=6)
    estimate = create("stereo_vo").run(data)
    assert estimate.poses_3d.shape == (6, 4, 4) and estimate.meta["scale"] == "metric"
    np.testing.assert_allclose(estimate.poses, top_view(estimate.poses_3d))
    assert np.all(estimate.step_time > 0) and estimate.diagnostics["inliers"][1:].min() >= 40
    # ≈ 0.8 m per frame forward along the top view's x
    assert 3.0 < estimate.poses[-1, 0] < 5.0 and abs(estimate.poses[-1, 1]) < 0.5
