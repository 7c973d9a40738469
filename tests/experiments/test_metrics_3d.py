"""3-D trajectory metrics: Umeyama against evo's, KITTI's relative error and the drift on constructed errors."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.estimators.vision.lie import so3_exp
from slamarena.experiments.metrics.trajectory3d import (
    align_umeyama,
    ate_3d,
    end_point_drift,
    kitti_relative_error,
    path_length,
)


def straight_then_turn(n=200, step=1.0):
    """T_world←cam along z, turning by 90° about y over the second half."""
    poses = np.tile(np.eye(4), (n, 1, 1))
    yaw = np.where(np.arange(n) < n // 2, 0.0, (np.arange(n) - n // 2) * (np.pi / 2) / (n // 2))
    position = np.zeros(3)
    for k in range(n):
        R = so3_exp(np.array([0.0, yaw[k], 0.0]))
        if k:
            position = position + R @ np.array([0.0, 0.0, step])
        poses[k, :3, :3], poses[k, :3, 3] = R, position
    return poses


def test_umeyama_is_evos(rng):
    from evo.core.geometry import umeyama_alignment

    p = rng.normal(size=(50, 3))
    q = 2.5 * p @ so3_exp(rng.normal(size=3)).T + rng.normal(size=3) + rng.normal(size=(50, 3)) * 0.01
    for with_scale in (False, True):
        s, R, t = align_umeyama(p, q, with_scale)
        R_evo, t_evo, s_evo = umeyama_alignment(p.T, q.T, with_scale)
        np.testing.assert_allclose(R, R_evo, atol=1e-12)
        np.testing.assert_allclose(t, t_evo, atol=1e-12)
        assert s == pytest.approx(s_evo)


def test_ate_is_zero_for_a_moved_copy_and_sim3_absorbs_scale(rng):
    gt = straight_then_turn()
    move = np.eye(4)
    move[:3, :3], move[:3, 3] = so3_exp(rng.normal(size=3)), rng.normal(size=3)
    moved = move @ gt
    assert ate_3d(moved, gt, "se3")["rmse"] < 1e-9
    scaled = moved.copy()
    scaled[:, :3, 3] *= 0.3
    assert ate_3d(scaled, gt, "se3")["rmse"] > 10
    result = ate_3d(scaled, gt, "sim3")
    assert result["rmse"] < 1e-9 and result["scale"] == pytest.approx(1 / 0.3)


def test_kitti_relative_error_of_a_one_percent_scale_error_is_one_percent():
    gt = straight_then_turn()
    long = gt.copy()
    long[:, :3, 3] *= 1.01
    result = kitti_relative_error(long, gt, [20, 50], step=5)
    # 1 % of the chord i → j: exactly 1 % on the straight half, a little less along the turn (chord < arc)
    assert 0.98 < result["t_rel_percent"] <= 1.0 + 1e-9 and result["r_rel_deg_per_100m"] < 1e-6
    assert result["per_length"][50.0]["segments"] == len(range(0, 200 - 50, 5))
    assert end_point_drift(long, gt)["percent_of_path"] == pytest.approx(
        100 * 0.01 * np.linalg.norm(gt[-1, :3, 3]) / path_length(gt)[-1]
    )
    with pytest.raises(ValueError, match="no segment"):
        kitti_relative_error(long, gt, [500])


def camera_sequence(truth):
    """A Sequence whose camera carries ``truth`` (K, 4, 4) as ground truth (images never read)."""
    from slamarena.datasets.sequence import Camera, Sequence

    n = len(truth)
    K = np.array([[700.0, 0, 600], [0, 700, 180], [0, 0, 1]])
    camera = Camera(t=0.1 * np.arange(n), left=np.array(["none.png"] * n), K=K, ground_truth=truth)
    return Sequence(name="cam", camera=camera)


def camera_estimate(data, poses_3d, t=None):
    from slamarena.datasets.estimate import Estimate
    from slamarena.estimators.vision.estimators import top_view

    t = data.camera.t if t is None else t
    return Estimate(method="vo", t=t, poses=top_view(poses_3d), poses_3d=poses_3d)


def test_registry_metrics_of_a_ten_percent_long_straight_trajectory_by_hand():
    """Straight along z at 1 m per frame, estimate 10 % long: by hand, t_rel = 10 % on every segment, r_rel = 0,
    drift = 10 % of the path, the Sim(3) alignment removes it all at scale 1/1.1; the SE(3) ATE is the RMSE of the
    residuals of the best rigid fit of 1.1 k onto k (k = 0 … 99), i.e. 0.1 |k − 49.5| → 0.1 · sqrt(mean (k − 49.5)²)."""
    from slamarena.experiments.metrics import METRICS, CellData, evaluate, reference_of

    n = 100
    truth = np.tile(np.eye(4), (n, 1, 1))
    truth[:, 2, 3] = np.arange(n)
    long = truth.copy()
    long[:, 2, 3] *= 1.1
    data = camera_sequence(truth)
    estimate = camera_estimate(data, long)
    selected = {"ate3d": METRICS["ate3d"].params(), "kitti_rel": METRICS["kitti_rel"].params(lengths=[10, 40], step=1)}
    scalars, series, skipped = evaluate(CellData(estimate, data, reference_of(data)), selected)
    assert skipped == {}
    ate, rel = scalars["ate3d"], scalars["kitti_rel"]
    k = np.arange(n)
    assert ate["rmse"] == pytest.approx(0.1 * np.sqrt(np.mean((k - 49.5) ** 2)))
    assert ate["percent"] == pytest.approx(100 * ate["rmse"] / 99)
    assert ate["sim3_rmse"] < 1e-9 and ate["sim3_scale"] == pytest.approx(1 / 1.1) and ate["path_m"] == 99
    assert rel["t_rel_percent"] == pytest.approx(10.0) and rel["r_rel_deg_per_100m"] == pytest.approx(0, abs=1e-9)
    assert rel["t_rel_sim3_percent"] == pytest.approx(0, abs=1e-9) and rel["drift_percent"] == pytest.approx(10.0)
    assert rel["segments"] == (n - 10) + (n - 40)
    np.testing.assert_allclose(series["ate3d"]["error"], 0.1 * np.abs(k - 49.5), atol=1e-9)


def test_registry_metrics_refuse_what_they_cannot_score():
    from slamarena.datasets.estimate import Estimate
    from slamarena.experiments.metrics import METRICS, CellData, evaluate, reference_of

    truth = straight_then_turn(20)
    data = camera_sequence(truth)
    selected = {"ate3d": METRICS["ate3d"].params(), "kitti_rel": METRICS["kitti_rel"].params()}
    planar = Estimate(method="planar", t=data.camera.t, poses=np.zeros((20, 3)))
    _, _, skipped = evaluate(CellData(planar, data, reference_of(data)), selected)
    assert "no 3-D trajectory" in skipped["ate3d"]
    shifted = camera_estimate(data, truth, t=data.camera.t + 0.05)
    _, _, skipped = evaluate(CellData(shifted, data, reference_of(data)), selected)
    assert "not the camera's frame times" in skipped["ate3d"]
    exact = camera_estimate(data, truth)
    _, _, skipped = evaluate(CellData(exact, data, reference_of(data)), selected)
    assert "no segment" in skipped["kitti_rel"]  # 19 m of path, the devkit's 100 m segments by default
    with pytest.raises(ValueError):
        METRICS["kitti_rel"].params(lengths=[])
