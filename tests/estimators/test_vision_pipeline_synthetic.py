"""The VO pipelines' parts on synthetic input: candidate matching against the masked table, and the windowed bundle
adjustment reducing the drift of a chained front end on a synthetic stereo drive."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.estimators.vision.backends import BACKENDS
from slamarena.estimators.vision.lie import se3_exp, so3_exp
from slamarena.estimators.vision.mono_vo import MonoVOParams
from slamarena.estimators.vision.projection import project
from slamarena.estimators.vision.stereo_vo import stereo_candidates
from slamarena.estimators.vision.window_ba import Observation, bundle_adjust

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])
B = 0.5372


def test_candidate_matching_equals_the_masked_table(rng):
    """``match_candidates`` on the pairs (i, j) equals ``match`` with ``allowed`` true exactly there (ours and
    OpenCV's), and ``stereo_candidates`` lists exactly the pairs of the dense row / disparity test."""
    for _ in range(20):
        a = rng.integers(0, 256, (300, 32), dtype=np.uint8)
        b = rng.integers(0, 256, (250, 32), dtype=np.uint8)
        flips = (rng.random((100, 32)) < 0.05) * rng.integers(0, 256, (100, 32))
        b[:100] = a[:100] ^ flips.astype(np.uint8)  # 100 near copies: real matches among random pairs
        allowed = rng.random((300, 250)) < 0.05
        allowed[np.arange(100), np.arange(100)] = rng.random(100) < 0.8
        i, j = np.nonzero(allowed)
        for backend in BACKENDS.values():
            dense = backend.match(a, b, 0.8, 120, allowed)
            sparse = backend.match_candidates(a, b, i, j, 0.8, 120)
            assert len(dense[0]) > 30 and all(np.array_equal(x, y) for x, y in zip(dense, sparse))
    ul, ur = rng.uniform([0, 0], [1241, 376], (400, 2)), rng.uniform([0, 0], [1241, 376], (500, 2))
    ur[:200, 1] = ul[:200, 1] + rng.uniform(-1.5, 1.5, 200)  # rows near the left ones
    i, j = stereo_candidates(ul, ur, 1.0, 2.0)
    dense = (np.abs(ul[:, None, 1] - ur[None, :, 1]) <= 1.0) & (ul[:, None, 0] - ur[None, :, 0] >= 2.0)
    assert sorted(zip(i, j)) == sorted(zip(*np.nonzero(dense))) and len(i) > 50


def test_a_monocular_window_must_hold_more_than_its_two_fixed_keyframes():
    with pytest.raises(ValueError, match="window"):
        MonoVOParams(window=2)
    assert MonoVOParams(window=0).window == 0 and MonoVOParams(window=3).window == 3


def _drive(n: int) -> list[np.ndarray]:
    """Keyframe poses T_world←cam (4, 4): 1.5 m apart along z, turning right by 0.02 rad per keyframe."""
    poses = []
    for k in range(n):
        T = np.eye(4)
        T[:3, :3] = so3_exp([0.0, 0.02 * k, 0.0])
        T[:3, 3] = [sum(1.5 * np.sin(0.02 * m) for m in range(k)), 0.0, sum(1.5 * np.cos(0.02 * m) for m in range(k))]
        poses.append(T)
    return poses


def _observe(T: np.ndarray, points: np.ndarray, rng, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Visible points' ids, left pixels (m, 2) and right columns (m,) with pixel noise σ, from T_world←cam."""
    R, t = T[:3, :3].T, -T[:3, :3].T @ T[:3, 3]
    depth = points @ R[2] + t[2]
    ids = np.flatnonzero((depth > 2.0) & (depth < 40.0))
    u = project(K, R, t, points[ids])
    ur = project(K, R, t - np.array([B, 0.0, 0.0]), points[ids])[:, 0]
    inside = (u[:, 0] > 0) & (u[:, 0] < 1241) & (u[:, 1] > 0) & (u[:, 1] < 376)
    ids, u, ur = ids[inside], u[inside], ur[inside]
    return ids, u + rng.normal(0, sigma, u.shape), ur + rng.normal(0, sigma, len(ur))


def test_windowed_bundle_adjustment_reduces_the_drift_of_a_chained_front_end(rng):
    """A synthetic stereo drive of 25 keyframes (36 m); the front end chains each keyframe onto the last with a
    relative-pose error (0.3° and 2 cm per step, a random walk) and places each keyframe's new points by its
    stereo pair (0.5 px noise). Windows of 5 keyframes (the oldest fixed), run as the pipeline runs them, must
    bring the end-point error below half of the chained one."""
    truth = _drive(25)
    points = np.column_stack([rng.uniform(-15, 25, 3000), rng.uniform(-3, 2, 3000), rng.uniform(0, 75, 3000)])
    seen = [_observe(T, points, rng, 0.5) for T in truth]
    steps = [np.linalg.inv(truth[k - 1]) @ truth[k] for k in range(1, len(truth))]
    errors = [se3_exp(np.r_[rng.normal(0, 0.02, 3), rng.normal(0, np.radians(0.3), 3)]) for _ in steps]

    def chained(adjust: bool) -> np.ndarray:
        poses = {0: truth[0].copy()}
        estimate = np.full(points.shape, np.nan)
        observations = []
        for k in range(len(truth)):
            if k:
                R, t = errors[k - 1]
                E = np.eye(4)
                E[:3, :3], E[:3, 3] = R, t
                poses[k] = poses[k - 1] @ steps[k - 1] @ E
            ids, u, ur = seen[k]
            new = ids[np.isnan(estimate[ids, 0])]
            for p, (uk, vk), rk in zip(ids, u, ur):
                observations.append(Observation(k, int(p), uk, vk, rk))
            if len(new):  # the keyframe's stereo triangulation of the points it sees first, in its own frame
                m = np.isin(ids, new)
                z = K[0, 0] * B / (u[m, 0] - ur[m])
                Xc = np.column_stack([(u[m, 0] - K[0, 2]) * z / K[0, 0], (u[m, 1] - K[1, 2]) * z / K[1, 1], z])
                estimate[ids[m]] = Xc @ poses[k][:3, :3].T + poses[k][:3, 3]
            if adjust and k >= 1:
                window = list(range(max(0, k - 4), k + 1))
                new_poses, new_points = bundle_adjust(
                    K, B, {w: poses[w] for w in window}, np.nan_to_num(estimate),
                    [o for o in observations if o.keyframe in window], (window[0],), min_views=2,
                )  # fmt: skip
                poses.update(new_poses)
                for p, X in new_points.items():
                    estimate[p] = X
        return poses[len(truth) - 1][:3, 3]

    end = truth[-1][:3, 3]
    drift_chain = np.linalg.norm(chained(False) - end)
    drift_ba = np.linalg.norm(chained(True) - end)
    assert drift_chain > 0.2  # the chained front end drifts (tens of centimetres over 36 m)
    assert drift_ba < 0.5 * drift_chain, (drift_ba, drift_chain)
