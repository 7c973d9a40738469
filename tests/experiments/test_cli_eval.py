"""``slamarena eval``: a trajectory file in any supported format against a dataset or a file, the numbers equal to
the metrics registry's on the same estimate."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import slamarena
from slamarena.datasets.formats import trajectories
from slamarena.experiments.cli import app
from slamarena.experiments.cli_eval import evaluate_file
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, RPEParams, ate, rpe


@pytest.fixture(scope="module")
def run():
    seq = slamarena.load("sim:landmarks")
    return seq, slamarena.create("dead_reckoning").run(seq)


@pytest.mark.parametrize("suffix", [".tum", ".csv", ".txt"])
def test_eval_against_a_dataset_equals_the_metrics(run, tmp_path, suffix):
    seq, est = run
    path = tmp_path / f"est{suffix}"
    trajectories.write(path, est.t, est.poses)
    out = evaluate_file(path, "sim:landmarks", ["ate", "rpe"], {"ate": {"align": "sim2"}})
    expected_ate, _ = ate(est, reference_of(seq), ATEParams(align="sim2"))
    expected_rpe, _ = rpe(est, reference_of(seq), RPEParams())
    assert out["metrics"]["ate"]["rmse"] == pytest.approx(expected_ate["rmse"], rel=1e-9)
    assert out["metrics"]["ate"]["scale"] == pytest.approx(expected_ate["scale"], rel=1e-9)
    assert out["metrics"]["rpe"]["trans_rmse"] == pytest.approx(expected_rpe["trans_rmse"], rel=1e-9)


def test_eval_kitti_with_times_and_g2o_against_files(run, tmp_path):
    seq, est = run
    truth = seq.ground_truth
    trajectories.write(tmp_path / "gt.tum", truth.t, truth.poses)
    trajectories.write(tmp_path / "est.kitti", est.t, est.poses)
    np.savetxt(tmp_path / "times.txt", est.t, fmt="%.17g")
    out = evaluate_file(
        tmp_path / "est.kitti", str(tmp_path / "gt.tum"), ["ate", "relations"], {}, times=tmp_path / "times.txt"
    )
    expected, _ = ate(est, reference_of(seq), ATEParams())
    assert out["metrics"]["ate"]["rmse"] == pytest.approx(expected["rmse"], rel=1e-9)
    assert "relations" in out["skipped"]  # a file reference has no relations
    # g2o: vertex ids are the times, on both sides
    k = np.searchsorted(truth.t, est.t)
    trajectories.write(tmp_path / "est.g2o", est.t, est.poses)
    trajectories.write(tmp_path / "gt.g2o", est.t, truth.poses[k])
    out = evaluate_file(tmp_path / "est.g2o", str(tmp_path / "gt.g2o"), ["ate"], {"ate": {"align": "none"}})
    assert out["metrics"]["ate"]["matched"] == len(est.t)
    err = np.hypot(*(est.poses[:, :2] - truth.poses[k, :2]).T)
    assert out["metrics"]["ate"]["rmse"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-9)


def test_the_command_prints_a_table_and_json(run, tmp_path):
    seq, est = run
    trajectories.write(tmp_path / "est.tum", est.t, est.poses)
    runner = CliRunner()
    table = runner.invoke(app, ["eval", str(tmp_path / "est.tum"), "--ref", "sim:landmarks"], env={"COLUMNS": "200"})
    assert table.exit_code == 0, table.output
    assert "rmse" in table.output and "trans_rmse" in table.output
    js = runner.invoke(
        app,
        ["eval", str(tmp_path / "est.tum"), "--ref", "sim:landmarks", "--metrics", "ate", "--align", "none", "--json"],
    )
    result = json.loads(js.output)
    expected, _ = ate(est, reference_of(seq), ATEParams(align="none"))
    assert result["metrics"]["ate"]["rmse"] == pytest.approx(expected["rmse"], rel=1e-9)
    bad = runner.invoke(app, ["eval", str(tmp_path / "est.tum"), "--ref", "sim:landmarks", "--align", "affine"])
    assert bad.exit_code == 2 and "align" in bad.output
    unknown = runner.invoke(app, ["eval", str(tmp_path / "est.tum"), "--ref", "sim:landmarks", "--metrics", "atee"])
    assert unknown.exit_code == 2 and "atee" in unknown.output
    fmt = runner.invoke(app, ["eval", str(tmp_path / "est.tum"), "--ref", "sim:landmarks", "--format", "kitty"])
    assert fmt.exit_code == 2 and "--format 'kitty'" in fmt.output


def test_version():
    from slamarena import __version__

    out = CliRunner().invoke(app, ["--version"])
    assert out.exit_code == 0 and out.output.strip() == f"slamarena {__version__}"


def test_eval_against_a_bag_with_a_truth_topic(tmp_path):
    from bags import robot_bag

    robot_bag(tmp_path / "run.bag")
    bag = slamarena.load(f"bag:{tmp_path / 'run.bag'}", truth_topic="/truth")
    est = slamarena.create("dead_reckoning").run(bag)
    trajectories.write(tmp_path / "est.tum", est.t, est.poses)
    args = ["eval", str(tmp_path / "est.tum"), "--ref", f"bag:{tmp_path / 'run.bag'}", "--metrics", "ate", "--json"]
    out = CliRunner().invoke(app, [*args, "--ref-param", "truth_topic=/truth", "--align", "none"])
    expected, _ = ate(est, reference_of(bag), ATEParams(align="none"))
    assert json.loads(out.output)["metrics"]["ate"]["rmse"] == pytest.approx(expected["rmse"], rel=1e-12)
    assert expected["rmse"] == pytest.approx(np.hypot(0.01, 0.01), rel=1e-6)  # the truth topic is odometry + (1, −1) cm
    without = json.loads(CliRunner().invoke(app, args).output)
    assert "ate" in without["skipped"]  # no truth topic named: no ground truth
