"""Every results cell writes ``groundtruth.tum`` beside ``trajectory.tum``: evo's APE on the pair, with no conversion,
equals our ATE; and an experiment config runs on a bag (laser + odometry, ground truth from a named topic)."""

from __future__ import annotations

import json
import os
import textwrap

import numpy as np
import pytest
from bags import robot_bag
from rich.console import Console

from slamarena.experiments.config import load_config
from slamarena.experiments.runner import run_experiment

SIM = """
name: gt
seeds: 1
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
estimators:
  - name: dead_reckoning
metrics: [ate]
figures: []
"""


def _run(tmp_path, text):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    out = tmp_path / "out"
    assert run_experiment(load_config(path), out, console=Console(file=open(os.devnull, "w"))) == 0
    return out


def test_evo_ape_on_the_cell_files_equals_our_ate(tmp_path):
    evo = pytest.importorskip("evo", reason="evo (the crosscheck extra) is not installed")
    from evo.core import metrics, sync
    from evo.tools import file_interface

    cell = next((_run(tmp_path, SIM) / "runs").glob("*/*/*"))
    ours = json.loads((cell / "metrics.json").read_text())["metrics"]["ate"]
    ref = file_interface.read_tum_trajectory_file(str(cell / "groundtruth.tum"))
    est = file_interface.read_tum_trajectory_file(str(cell / "trajectory.tum"))
    ref, est = sync.associate_trajectories(ref, est, max_diff=1e-6)
    assert est.num_poses == ours["matched"]
    est.align(ref, correct_scale=False)  # Umeyama in SE(3); planar poses → the SE(2) alignment of ours
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(ours["rmse"], rel=1e-9, abs=1e-12)
    assert ape.get_statistic(metrics.StatisticsType.max) == pytest.approx(ours["max"], rel=1e-9, abs=1e-12)
    assert ours["rmse"] > 0.01 and evo.__version__


def test_a_config_runs_grid_slam_and_dead_reckoning_on_a_bag(tmp_path):
    written = robot_bag(tmp_path / "run.bag")
    out = _run(
        tmp_path,
        f"""
        name: bag
        seeds: 1
        datasets:
          - name: bag
            label: robot
            params: {{path: {tmp_path / "run.bag"}, truth_topic: /truth}}
        estimators:
          - name: dead_reckoning
          - name: grid_slam
        metrics: [ate]
        figures: []
        """,
    )
    for method in ("dead_reckoning", "grid_slam"):
        cell = out / "runs" / "robot" / method / "0"
        assert json.loads((cell / "metrics.json").read_text())["status"] == "ok"
        truth = np.loadtxt(cell / "groundtruth.tum")
        np.testing.assert_allclose(truth[:, 0], written["t_odom"])
        np.testing.assert_allclose(truth[:, 1:3], written["truth"][:, :2], atol=1e-12)


def test_a_config_refuses_a_landmark_method_on_a_laser_bag_before_any_cell_runs(tmp_path):
    from slamarena.experiments.config import ConfigError

    robot_bag(tmp_path / "run.bag")
    path = tmp_path / "exp.yaml"
    path.write_text(
        textwrap.dedent(f"""
        name: bad
        datasets:
          - name: bag
            params: {{path: {tmp_path / "run.bag"}}}
        estimators:
          - name: ekf_slam
        """)
    )
    with pytest.raises(ConfigError, match="needs range_bearing"):
        load_config(path)
