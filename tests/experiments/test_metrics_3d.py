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
