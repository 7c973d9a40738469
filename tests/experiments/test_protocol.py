"""The leave-one-log-out protocol: choices worked out by hand on a small score table, the config's checks, and a tiny
run that writes the held-out table."""

from __future__ import annotations

import json
import math
import os
import textwrap

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from slamarena.experiments.config import ConfigError, load_config
from slamarena.experiments.protocol import ProtocolSpec, leave_one_out
from slamarena.experiments.runner import run_experiment


def _frame(scores: dict, column: str = "relations.trans_mean", failed=()) -> pd.DataFrame:
    rows = []
    for d, by_candidate in scores.items():
        for c, v in by_candidate.items():
            status = "error" if (d, c) in failed else "ok"
            col = "refrel.trans_mean" if d.endswith("_corrected") else column
            rows.append({"dataset": d, "estimator": c, "status": status, col: v})
    return pd.DataFrame(rows)


SPEC = ProtocolSpec(score=["relations.trans_mean", "refrel.trans_mean"], candidates={"m": ["a", "b"]})


def test_choices_by_hand():
    """S = d1: (a 1, b 2), d2: (a 1, b 2), d3_corrected: (a 10, b 1). Held out d1: on d2, d3 Σ log is a: log 10,
    b: log 2 → b, 2 (oracle a, 1); d2 likewise; d3: on d1, d2 a: 0, b: 2 log 2 → a, 10 (oracle b, 1). Shipped (all
    three): a: log 10 > b: 2 log 2 → b; the all row: geometric means (2·2·10)^⅓ and 1."""
    frame = _frame({"d1": {"a": 1.0, "b": 2.0}, "d2": {"a": 1.0, "b": 2.0}, "d3_corrected": {"a": 10.0, "b": 1.0}})
    table, shipped = leave_one_out(frame, SPEC, ["d1", "d2", "d3_corrected"])
    rows = table.set_index("dataset")
    assert list(rows.loc[["d1", "d2", "d3_corrected"], "chosen"]) == ["b", "b", "a"]
    assert list(rows.loc[["d1", "d2", "d3_corrected"], "held_out"]) == [2.0, 2.0, 10.0]
    assert list(rows.loc[["d1", "d2", "d3_corrected"], "oracle_choice"]) == ["a", "a", "b"]
    assert (
        rows.loc["d3_corrected", "score"] == "refrel.trans_mean" and rows.loc["d1", "score"] == "relations.trans_mean"
    )
    assert shipped == {"m": "b"} and rows.loc["all", "chosen"] == "b"
    assert math.isclose(rows.loc["all", "held_out"], 40 ** (1 / 3)) and rows.loc["all", "oracle"] == 1.0


def test_a_failed_cell_is_never_chosen_and_ties_take_the_first():
    frame = _frame(
        {"d1": {"a": 1.0, "b": 5.0}, "d2": {"a": 1.0, "b": 5.0}, "d3": {"a": 3.0, "b": 3.0}}, failed={("d1", "a")}
    )
    table, shipped = leave_one_out(frame, SPEC, ["d1", "d2", "d3"])
    rows = table.set_index("dataset")
    assert rows.loc["d2", "chosen"] == "b"  # a failed on d1, which is in d2's training set
    assert rows.loc["d1", "chosen"] == "a" and np.isnan(rows.loc["d1", "held_out"])  # a failed where it is scored
    assert rows.loc["d1", "oracle_choice"] == "b" and shipped == {"m": "b"}
    tie = _frame({"d1": {"a": 2.0, "b": 2.0}, "d2": {"a": 1.0, "b": 1.0}})
    assert leave_one_out(tie, SPEC, ["d1", "d2"])[1] == {"m": "a"}


TINY = """
name: tiny
seeds: 1
timeout: 120
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
    label: w1
  - name: sim:landmarks
    params: {n_landmarks: 9, laps: 1}
    label: w2
estimators:
  - name: dead_reckoning
    label: euler
    params: {motion_model: euler}
  - name: dead_reckoning
    label: arc
    params: {motion_model: arc}
metrics: [ate]
protocol:
  score: [ate.rmse]
  candidates: {dead_reckoning: [euler, arc]}
figures: []
"""


def _write(tmp_path, text):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.mark.parametrize(
    "change, message",
    [
        (("[euler, arc]", "[euler]"), "at least two distinct candidate labels"),
        (("[euler, arc]", "[euler, nope]"), "'nope' is no estimator label"),
        (("{dead_reckoning: [euler, arc]}", "{ekf_slam: [euler, arc]}"), "'euler' is method 'dead_reckoning'"),
        (("score: [ate.rmse]", "score: [ate.matched]"), "not a lower-is-better column"),
        (("score: [ate.rmse]", "score: [rpe.trans_rmse]"), "needs metric 'rpe' enabled"),
        (
            ("    params: {motion_model: arc}\n", "    params: {motion_model: arc}\n    datasets: [w1]\n"),
            "every dataset",
        ),
    ],
)
def test_a_bad_protocol_is_rejected_with_its_path(tmp_path, change, message):
    text = TINY.replace(*change)
    with pytest.raises(ConfigError, match=message) as err:
        load_config(_write(tmp_path, text))
    assert "protocol" in str(err.value)


def test_a_run_writes_the_heldout_table_and_the_shipped_choice(tmp_path):
    cfg = load_config(_write(tmp_path, TINY))
    code = run_experiment(cfg, tmp_path / "out", console=Console(file=open(os.devnull, "w")))
    assert code == 0
    heldout = pd.read_csv(tmp_path / "out" / "tables" / "heldout.csv")
    assert list(heldout["dataset"]) == ["w1", "w2", "all"] and set(heldout["chosen"]) <= {"euler", "arc"}
    record = json.loads((tmp_path / "out" / "protocol.json").read_text())
    assert record["shipped"]["dead_reckoning"]["label"] in ("euler", "arc")
    assert record["shipped"]["dead_reckoning"]["params"]["motion_model"] == record["shipped"]["dead_reckoning"]["label"]
    part = cfg.reduced(estimators=["euler"])
    assert part.protocol is None  # one candidate left: nothing to choose
