"""EKF localizer on a withheld recording's terms: a sequence that states no start pose (MRCLAM Dataset 1) and a
surveyed map with a wrong landmark (Dataset 1 has two swapped). The start pose is fitted to the first landmark rows
(estimators/ekf_localizer/start.py); the lock-out guard does not force in one landmark refused alone
(research/notebook/2026-11-28-mrclam-withheld.md)."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import LandmarkMap, Sequence
from slamarena.estimators.ekf_localizer import EKFLocalizer
from slamarena.estimators.ekf_localizer.start import fit_start
from slamarena.estimators.models import observe
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def _localizer(**kw) -> EKFLocalizer:
    return EKFLocalizer(motion_model="arc", Q=0.0, use_sequence_noise=True, **kw)


@pytest.fixture(scope="module")
def world() -> Sequence:
    return datasets.load("sim:landmarks", seed=0)  # starts at (−6.95, −8.65, 0): 11 m from the origin


def _unstated(seq: Sequence, **changes) -> Sequence:
    """The sequence as a recording without Vicon states it: no initial pose, no ground truth."""
    return Sequence(**{**seq.__dict__, "initial_pose": None, "ground_truth": None, **changes})


def test_fit_start_recovers_the_pose_and_its_covariance_matches_monte_carlo():
    rng = np.random.default_rng(0)
    s = np.array([1.5, -2.0, 2.5])
    p = rng.uniform(-3, 3, (6, 2))
    C = np.stack([np.diag([0.02, 0.005]), np.diag([0.01, 0.03])] * 3)
    m = np.array([compose(s, np.r_[q, 0.0])[:2] for q in p])
    fitted, cov, d2 = fit_start(p, C, m)
    np.testing.assert_allclose(fitted, s, atol=1e-9)
    assert d2.max() < 1e-12
    L = np.linalg.cholesky(C)
    draws = np.array(
        [fit_start(p + np.einsum("nij,nj->ni", L, rng.standard_normal((6, 2))), C, m)[0] for _ in range(3000)]
    )
    err = draws - s
    err[:, 2] = wrap_angle(err[:, 2])
    empirical = err.T @ err / len(err)
    # every direction's variance within 10 % of the stated one (3000 draws: ±5 % sampling error)
    w = np.linalg.eigvalsh(
        np.linalg.solve(np.linalg.cholesky(cov), np.linalg.solve(np.linalg.cholesky(cov), empirical).T)
    )
    assert np.all(np.abs(w - 1.0) < 0.1), w


def test_a_sequence_without_a_start_pose_starts_where_its_landmarks_put_it(world):
    truth = reference_of(world)
    stated = _localizer().run(world)
    fitted = _localizer().run(_unstated(world))
    origin = _localizer().run(_unstated(world, initial_pose=np.zeros(3)))  # what "unknown" used to mean
    assert fitted.meta["start"]["from"] == "landmarks" and stated.meta["start"] == {"from": "sequence"}
    error = fitted.poses[0] - world.start_pose
    error[2] = wrap_angle(error[2])
    assert error @ np.linalg.solve(fitted.pose_cov[0], error) < 16.3  # χ²₃(0.999)
    score = {
        k: ate(e, truth, ATEParams(align="none"))[0]["rmse"] for k, e in [("s", stated), ("f", fitted), ("o", origin)]
    }
    assert score["f"] < 1.2 * score["s"] + 0.01, score
    assert score["o"] > 10 * score["f"], score


def test_one_wrong_surveyed_landmark_is_left_out_of_the_start_fit(world):
    lm = world.landmarks
    first = [int(i) for i in dict.fromkeys(world.range_bearing.landmark_id)][:2]  # the first two landmarks seen
    xy = lm.xy.copy()
    a, b = (int(np.flatnonzero(lm.ids == i)[0]) for i in first)
    xy[[a, b]] = xy[[b, a]]  # swapped against their ids, as Dataset 1's 11 and 17
    est = _localizer().run(_unstated(world, landmarks=LandmarkMap(ids=lm.ids, xy=xy)))
    start = est.meta["start"]
    assert start["from"] == "landmarks" and set(start["dropped"]) & set(first)
    error = est.poses[0] - world.start_pose
    error[2] = wrap_angle(error[2])
    assert error @ np.linalg.solve(est.pose_cov[0], error) < 16.3


def test_one_landmark_refused_alone_is_not_forced_in_and_two_are():
    pose = np.array([1.0, 0.0, 0.0])  # where the robot is
    R = np.diag([0.01, 0.0025])
    wrong = _filter_at(pose, R)
    seen = observe(pose, np.array([5.0, 2.0]))  # the landmark stands at (5, 2); the map says (5, 0)
    for _ in range(20):
        assert not wrong.update_landmark(*seen, (5.0, 0.0))
    assert wrong.recoveries["landmark"] == 0 and np.allclose(wrong.x, pose)
    # another landmark agrees with the filter: the refused one is suspect; a second wrong one (a swapped pair) refused
    # with it is one unsuspected reference, still not two
    assert wrong.update_landmark(*observe(pose, np.array([0.0, 5.0])), (0.0, 5.0))
    other = observe(pose, np.array([2.0, -5.0]))  # stands at (2, −5); the map says (0, −5)
    for k in range(20):
        assert not (wrong.update_landmark(*other, (0.0, -5.0)) if k % 2 else wrong.update_landmark(*seen, (5.0, 0.0)))
    assert wrong.recoveries["landmark"] == 0 and np.allclose(wrong.x, pose, atol=1e-3)

    lost = _filter_at(np.zeros(3), R)  # the filter, not the map, is off by 1 m
    a, b = np.array([5.0, 0.0]), np.array([0.0, 5.0])
    for k in range(6):  # five refusals in a row of two landmarks: the sixth row is taken with P inflated
        m = a if k % 2 else b
        lost.update_landmark(*observe(pose, m), m)
    assert lost.recoveries["landmark"] == 1 and 0.0 < lost.x[0] < pose[0]  # taken: moved towards the robot


def _filter_at(pose, R) -> EKFLocalizer:
    f = EKFLocalizer(R_landmark=R.tolist(), initial_cov=(1e-4, 1e-4, 1e-4))
    f.reset(pose)
    return f
