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


def test_identify_noise_command_states_the_library_result_from_a_given_start():
    """`slamarena identify-noise`: the start given by --param (16× the simulator's), the filter's other parameters and
    the dataset's keywords reach identify(); it prints the same exponents and model as the library call."""
    import json

    from typer.testing import CliRunner

    from slamarena.experiments.cli import app

    truth = _world().noise
    start = (16.0 * truth.range_bearing_cov).tolist()
    args = [
        "identify-noise",
        "sim:landmarks",
        "--entry",
        "range_bearing_cov=0,1",
        "--param",
        f"range_bearing_cov={start}",
    ]
    args += ["--param", f"twist_cov={truth.twist_cov.tolist()}", "--dataset-param", "n_landmarks=20"]
    result = CliRunner().invoke(app, [*args, "--dataset-param", "seed=1"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["exponents"] == {"range_bearing_cov[0]": -2, "range_bearing_cov[1]": -2}
    np.testing.assert_allclose(out["model"]["range_bearing_cov"], truth.range_bearing_cov, rtol=1e-12)
    assert out["score"]["rows"] > 0 and out["models_evaluated"] >= 3


def test_identify_noise_command_rejects_a_malformed_entry():
    from typer.testing import CliRunner

    from slamarena.experiments.cli import app

    result = CliRunner().invoke(app, ["identify-noise", "sim:landmarks", "--entry", "range_bearing_cov:0"])
    assert result.exit_code == 2 and "NAME=I,J" in result.output
