"""Windowed bundle adjustment (GTSAM stereo and projection factors) on a synthetic stereo rig."""

from __future__ import annotations

import numpy as np

from slamarena.estimators.vision.lie import se3_exp, so3_exp
from slamarena.estimators.vision.projection import project
from slamarena.estimators.vision.window_ba import Observation, bundle_adjust

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])
B = 0.5372


def test_bundle_adjustment_recovers_the_rig_from_perturbed_poses_and_points(rng):
    poses = {}
    for k in range(4):  # T_world←cam driving forward along z, turning slowly
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = so3_exp([0.0, 0.03 * k, 0.0]), [0.1 * k, 0.0, 1.0 * k]
        poses[k] = T
    points = rng.uniform([-8, -2, 8], [8, 2, 30], size=(120, 3))
    observations = []
    for k, T in poses.items():
        R, t = T[:3, :3].T, -T[:3, :3].T @ T[:3, 3]  # T_cam←world
        u = project(K, R, t, points)
        u_right = project(K, R, t - np.array([B, 0, 0]), points)[:, 0]
        for p in range(len(points)):
            stereo = p % 3 == k % 3  # each point seen in stereo by some keyframes, monocular by the others
            observations.append(Observation(k, p, *u[p], u_right[p] if stereo else np.nan))
    start = {k: T.copy() for k, T in poses.items()}
    for k in (1, 2, 3):
        dR, dt = se3_exp(rng.normal(size=6) * 0.02)
        start[k][:3, :3], start[k][:3, 3] = dR @ start[k][:3, :3], dR @ start[k][:3, 3] + dt
    noisy = points + rng.normal(size=points.shape) * 0.1
    new_poses, new_points = bundle_adjust(K, B, start, noisy, observations, fixed=(0,))
    for k in poses:
        np.testing.assert_allclose(new_poses[k], poses[k], atol=1e-6)
    np.testing.assert_allclose(np.array([new_points[p] for p in range(len(points))]), points, atol=1e-5)
    # a window of keyframe 3 alone: the points it sees only monocularly (once) stay out, its stereo points are placed
    _, some = bundle_adjust(K, B, {3: poses[3]}, noisy, observations, fixed=(3,))
    assert set(some) == {p for p in range(len(points)) if p % 3 == 0}
    np.testing.assert_allclose(np.array([some[p] for p in sorted(some)]), points[sorted(some)], atol=1e-5)
