"""Sensor-model identification by the innovation likelihood (experiments.noise_identification): it recovers a simulator's
observation noise from a model stated 16× too large, and scoring the innovations leaves the filter's estimate unchanged."""

from __future__ import annotations

import numpy as np

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.noise_identification import _Scoring, identify, innovation_score


def _world():
    return datasets.load("sim:landmarks", n_landmarks=20, seed=1)


def test_identification_returns_to_the_simulators_observation_noise_from_a_model_stated_16_times_too_large():
    seq = _world()
    truth = {"range_bearing_cov": seq.noise.range_bearing_cov, "twist_cov": seq.noise.twist_cov}
    stated = {**truth, "range_bearing_cov": 16.0 * truth["range_bearing_cov"]}
    found = identify(seq, {}, stated, {"range_bearing_cov": [0, 1]})
    assert found.exponents == {("range_bearing_cov", 0): -2, ("range_bearing_cov", 1): -2}
    np.testing.assert_allclose(found.model["range_bearing_cov"], truth["range_bearing_cov"], rtol=1e-12)
    assert found.score == innovation_score(seq, {k: v.tolist() for k, v in truth.items()})
    assert found.score.loglik > max(s.loglik for k, s in found.trace if k != found.exponents) - 1e-12
    assert abs(found.score.nis_per_dof - 1.0) < 0.1  # the true model is consistent


def test_scoring_leaves_the_estimate_unchanged_and_counts_every_labelled_reobservation():
    seq = _world()
    plain = EKFSLAM().run(seq)
    scoring = _Scoring()
    scored = scoring.run(seq)
    np.testing.assert_array_equal(scored.poses, plain.poses)
    ids = seq.range_bearing.landmark_id
    assert len(scoring.scored) == len(ids) - len(np.unique(ids))  # every row but each landmark's first
