"""A config's claims: validated against its grid before anything runs, checked on a run's summary and Monte Carlo
table (absolute and relative bounds, every matching row), kept by a reduced config where they still apply, ignored by
the shipped-run comparison, and failing a run's exit code."""

from __future__ import annotations

import io
import json
import os
import textwrap

import pandas as pd
import pytest
from rich.console import Console

from slamarena.experiments.claims import Claim, check_claims, check_shipped, print_results
from slamarena.experiments.config import ConfigError, load_config
from slamarena.experiments.quote import not_shipped
from slamarena.experiments.results import MANIFEST, SUMMARY

GRID = """
name: grid
seeds: 2
timeout: 120
datasets:
  - {name: sim:landmarks, label: a, params: {n_landmarks: 8, laps: 1}}
  - {name: sim:landmarks, label: b, params: {n_landmarks: 9, laps: 1}}
estimators:
  - name: dead_reckoning
  - {name: ekf_slam, label: ekf, datasets: [a]}
metrics: [ate, nees]
figures: []
"""


def _load(tmp_path, claims: str, text: str = GRID):
    path = tmp_path / "c.yaml"
    path.write_text(textwrap.dedent(text) + textwrap.dedent(claims))
    return load_config(path)


def _summary(out, rows):
    out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(out / SUMMARY, index=False)


@pytest.mark.parametrize(
    "claims, message",
    [
        (
            "claims:\n  - {claim: x, column: ate.rmsd, rows: a/ekf, below: 1}",
            "claims.0: claim 'x': unknown column 'ate.rmsd' for table summary",
        ),
        (
            "claims:\n  - {claim: x, column: ate.rmse, rows: b/ekf, below: 1}",
            "claims.0: claim 'x': rows=b/ekf matches no cell",
        ),
        (
            "claims:\n  - {claim: x, column: ate.rmse, rows: b/dead_reckoning, below: {estimator: ekf}}",
            "the reference row(s) b/ekf are not in the grid",
        ),
        ("claims:\n  - {claim: x, column: ate.rmse, rows: a/ekf}", "give 'below', 'above' or both"),
        ("claims:\n  - {claim: x, column: ate.rmse, rows: ekf, below: 1}", "is not DATASET/ESTIMATOR"),
        ("claims:\n  - {claim: x, column: ate.rmse, rows: a/ekf, below: {times: 2}}", "names the reference row's"),
        ("claims:\n  - {claim: x, column: ate.rmse, rows: a/ekf, table: monte_carlo, below: 1}", "unknown column"),
    ],
)
def test_a_claim_that_cannot_be_checked_is_rejected_before_anything_runs(tmp_path, claims, message):
    with pytest.raises(ConfigError, match="claims.0") as info:
        _load(tmp_path, claims)
    assert message in str(info.value)


def test_absolute_and_relative_bounds_on_every_matching_row(tmp_path):
    config = _load(
        tmp_path,
        """
        claims:
          - claim: the EKF beats dead reckoning by half
            column: ate.rmse
            rows: a/ekf
            below: {estimator: dead_reckoning, times: 0.5}
          - claim: dead reckoning drifts, on both worlds
            column: ate.rmse
            rows: "*/dead_reckoning"
            above: 1.0
            below: 3.0
        """,
    )
    out = tmp_path / "run"
    ok = {"status": "ok"}
    _summary(
        out,
        [
            {"dataset": "a", "estimator": "dead_reckoning", "seed": 0, "ate.rmse": 2.0, **ok},
            {"dataset": "a", "estimator": "dead_reckoning", "seed": 1, "ate.rmse": 4.0, **ok},  # mean 3.0: not below 3
            {"dataset": "b", "estimator": "dead_reckoning", "seed": 0, "ate.rmse": 2.0, **ok},
            {"dataset": "a", "estimator": "ekf", "seed": 0, "ate.rmse": 1.0, **ok},
            {"dataset": "a", "estimator": "ekf", "seed": 1, "ate.rmse": 9.0, "status": "failed"},  # not averaged
        ],
    )
    results = {(r.claim[:6], r.row): r for r in check_claims(config.claims, out)}
    assert [r.holds for r in results.values()] == [True, False, True]
    relative = results[("the EK", "a/ekf")]
    assert relative.value == 1.0 and relative.bounds == ("below 0.5 × a/dead_reckoning = 1.5",)
    assert results[("dead r", "a/dead_reckoning")].bounds == ("above 1", "below 3")
    lines = []
    assert not print_results(list(results.values()), "grid", lines.append)
    assert lines[0] == "grid: 1 of 3 claim checks do not hold (the config's claims: in its YAML):"
    assert (
        lines[1]
        == "  DOES NOT HOLD: dead reckoning drifts, on both worlds — a/dead_reckoning ate.rmse = 3, above 1 and below 3"
    )


def test_a_row_without_a_value_does_not_hold(tmp_path):
    config = _load(tmp_path, "claims:\n  - {claim: x, column: nees.mean_over_dof, rows: a/ekf, above: 0.5}")
    out = tmp_path / "run"
    _summary(out, [{"dataset": "a", "estimator": "ekf", "seed": 0, "status": "failed", "ate.rmse": 1.0}])
    (result,) = check_claims(config.claims, out)
    assert not result.holds and result.bounds == ("no such row in the run",)


def test_a_monte_carlo_claim_reads_the_monte_carlo_table(tmp_path):
    config = _load(
        tmp_path,
        """
        claims:
          - {claim: in band, column: in_band, table: monte_carlo, rows: "*/ekf/nees", above: 0.9}
          - {claim: no better, column: mean_over_dof, table: monte_carlo, rows: a/ekf/nees, below: {estimator: dead_reckoning}}
        """,
    )
    out = tmp_path / "run"
    (out / "tables").mkdir(parents=True)
    pd.DataFrame(
        [
            {"dataset": "a", "estimator": "ekf", "statistic": "nees", "in_band": 0.95, "mean_over_dof": 1.1},
            {"dataset": "a", "estimator": "dead_reckoning", "statistic": "nees", "in_band": 0.1, "mean_over_dof": 1.0},
        ]
    ).to_csv(out / "tables" / "monte_carlo.csv", index=False)
    first, second = check_claims(config.claims, out)
    assert first.holds and first.row == "a/ekf/nees"
    assert not second.holds and second.bounds == ("below a/dead_reckoning/nees = 1",)


def test_a_reduced_config_keeps_the_claims_that_still_apply(tmp_path):
    config = _load(
        tmp_path,
        """
        claims:
          - {claim: one, column: ate.rmse, rows: a/ekf, below: {estimator: dead_reckoning}}
          - {claim: two, column: ate.rmse, rows: "*/dead_reckoning", below: 5}
        """,
    )
    assert [c.claim for c in config.reduced(datasets=["b"]).claims] == ["two"]
    assert [c.claim for c in config.reduced(estimators=["ekf"]).claims] == []
    assert [c.claim for c in config.reduced(seeds=1).claims] == ["one", "two"]


def test_claims_are_not_a_difference_from_the_shipped_config(tmp_path):
    """A run made before a config stated its claims (or after they were edited) is still a run of the shipped config."""
    shipped = load_config("gps_sweep").model_dump(mode="json")
    shipped.pop("claims")
    (tmp_path / MANIFEST).write_text(json.dumps({"experiment": "gps_sweep", "config": shipped}))
    assert not_shipped(tmp_path) == []


def test_results_lists_the_configs_whose_claims_it_could_not_check(tmp_path):
    lines = []
    assert check_shipped(tmp_path, lines.append) == 0
    with_claims = [name for name in ("gps_sweep", "localizer_q_unit") if load_config(name).claims]
    assert with_claims and all(
        any(line.startswith(f"{n}: claims not checked (no run") for line in lines) for n in with_claims
    )


def test_a_claim_that_does_not_hold_fails_the_run(tmp_path):
    from slamarena.experiments.runner import run_experiment

    config = _load(
        tmp_path,
        "claims:\n  - {claim: dead reckoning is perfect, column: ate.rmse, rows: a/dead_reckoning, below: 1.0e-9}",
        GRID.replace("seeds: 2", "seeds: 1"),
    ).reduced(estimators=["dead_reckoning"], datasets=["a"])
    buffer = io.StringIO()
    assert run_experiment(config, tmp_path / "out", console=Console(file=buffer, width=200)) == 1
    assert "DOES NOT HOLD: dead reckoning is perfect — a/dead_reckoning ate.rmse =" in buffer.getvalue()
    assert Claim.model_validate(config.claims[0].model_dump()).below == 1e-9
    assert os.path.isfile(tmp_path / "out" / SUMMARY)
