"""EKF-SLAM's self-identification of its noise scales without ids (``self_identify``,
:mod:`slamarena.estimators.ekf_slam.self_identification`; research/method/ekf_slam_adaptive_noise.md): the median test
holds its level and sees a wrong model, a simulator's exact model is kept bitwise, a stated R 4× too large is found."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.self_identification import median_test

GATE = chi2.ppf(0.95, 2)


def _truncated_chi2(rng, n: int, scale: float = 1.0) -> np.ndarray:
    """n NIS values of 2-dof innovations whose covariance is ``scale`` × the one they are normalised by, kept below GATE."""
    d2 = scale * rng.chisquare(2, size=4 * n)
    return d2[d2 < GATE][:n]


def test_the_median_test_holds_its_level_and_sees_a_scaled_innovation_covariance(rng):
    """Right model: rejected at confidence 0.99 in about 1 % of 2000 draws of 500 rows; innovations 4× smaller or 4×
    larger (truncated to the gate) than the model says: rejected every time; no rows: not rejected."""
    rejected = [median_test(_truncated_chi2(rng, 500), GATE, 0.99)[0] for _ in range(2000)]
    assert 0.003 < np.mean(rejected) < 0.02
    assert all(median_test(_truncated_chi2(rng, 500, 0.25), GATE, 0.99999)[0] for _ in range(20))
    assert all(median_test(_truncated_chi2(rng, 500, 4.0), GATE, 0.99999)[0] for _ in range(20))
    assert median_test(np.zeros(0), GATE, 0.99) == (False, 0.0)


def _world(seed: int):
    return datasets.load("sim:landmarks", n_landmarks=25, layout="grid", density=0.03, seed=seed)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_exact_model_is_kept_bitwise(seed):
    """The simulator's own noise, ids withheld: the test does not reject it, the scales stay 1 and the estimate is
    bitwise the one without self-identification (an adaptation must not inflate the noise of a correct model)."""
    seq = _world(seed)
    ekf = EKFSLAM(use_ids=False, self_identify=True)
    est = ekf.run(seq)
    plain = EKFSLAM(use_ids=False, self_identify=False).run(seq)
    found = est.meta["noise_identification"]
    assert not found["rejected"] and (found["q_scale"], found["r_scale"]) == (1.0, 1.0)
    assert (ekf.q_scale, ekf.r_scale) == (1.0, 1.0) and len(found["runs"]) == 1
    np.testing.assert_array_equal(est.poses, plain.poses)
    np.testing.assert_array_equal(est.landmarks, plain.landmarks)


def test_a_sensor_noise_stated_4x_too_large_is_found_and_the_filter_ends_in_its_run():
    """The simulator's R stated 4× too large (ids withheld; the grid 4^−1 … 4^1): the median test rejects it, the search
    finds r = 1/4, and the run returned is bitwise a plain run on the scales chosen (4 and 1/4 are exact in binary), the
    filter left in its state. As measured, the likelihood also takes q = 4 here (L 6355 against 6022 at q = 1 with the
    true R; research/notebook/2026-11-28-ekf-adaptive-noise.md): the scales are the run's most likely, not the truth."""
    seq = _world(0)
    R, M = seq.noise.range_bearing_cov, seq.noise.twist_cov
    ekf = EKFSLAM(use_ids=False, self_identify=True, noise_steps=1, range_bearing_cov=4 * R)
    est = ekf.run(seq)
    found = est.meta["noise_identification"]
    assert found["rejected"] and found["r_scale"] == 0.25
    q = found["q_scale"]
    assert (ekf.q_scale, ekf.r_scale) == (q, 0.25) and est.meta["noise_scale"] == {"q": q, "r": 0.25}
    np.testing.assert_array_equal(est.poses[-1], ekf.x[:3])
    plain = EKFSLAM(use_ids=False, self_identify=False, range_bearing_cov=R, twist_cov=q * M).run(seq)
    np.testing.assert_array_equal(est.poses, plain.poses)
    np.testing.assert_array_equal(est.landmarks, plain.landmarks)


def test_labelled_runs_and_the_default_are_not_identified():
    """With the ids trusted (use_ids=True), or by default (self_identify=False), the stated noise is used as it is."""
    est = EKFSLAM(self_identify=True, range_bearing_cov=16 * _world(0).noise.range_bearing_cov).run(_world(0))
    assert "noise_identification" not in est.meta and est.meta["noise_scale"] == {"q": 1.0, "r": 1.0}
    est = EKFSLAM(use_ids=False, range_bearing_cov=16 * _world(0).noise.range_bearing_cov).run(_world(0))
    assert "noise_identification" not in est.meta and est.meta["noise_scale"] == {"q": 1.0, "r": 1.0}
