"""A dataset entry's ``landmarks:`` (the extraction of mapping/landmark_extraction.py applied after loading): validated
with the config, part of the cell's cache key, refused on a dataset without scans, and run: EKF-SLAM without ids on
the poles the scans of ``sim:laser``'s pole field show."""

from __future__ import annotations

import json
import os
import textwrap

import pytest
from rich.console import Console

from slamarena.experiments.config import ConfigError, load_config
from slamarena.experiments.plan import plan
from slamarena.experiments.runner import run_experiment

POLES = """
name: poles
seeds: 1
datasets:
  - name: sim:laser
    params: {world: poles, fov: 3.141592653589793, max_range: 40.0, sigma_range: 0.02, speed: 1.0}
    landmarks: {features: poles, min_beams: 2, sigma_range: 0.02}
estimators:
  - name: dead_reckoning
  - name: ekf_slam
    params: {use_ids: false, association: jcbb}
metrics:
  ate: {}
  map: {by: nearest}
figures: []
"""


def _write(tmp_path, text):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_extraction_parameters_are_checked_with_the_config(tmp_path):
    with pytest.raises(ConfigError, match=r"landmarks.*features"):
        load_config(_write(tmp_path, POLES.replace("features: poles", "features: trees")))
    with pytest.raises(ConfigError, match="has landmarks to extract but sim:landmarks has no scans"):
        load_config(
            _write(
                tmp_path,
                POLES.replace("name: sim:laser", "name: sim:landmarks").replace(
                    "params: {world: poles, fov: 3.141592653589793, max_range: 40.0, sigma_range: 0.02, speed: 1.0}", ""
                ),
            )
        )
    keys = {c.key for c in plan(load_config(_write(tmp_path, POLES)), tmp_path / "out")}
    other = {
        c.key for c in plan(load_config(_write(tmp_path, POLES.replace("min_beams: 2", "min_beams: 3"))), tmp_path)
    }
    assert not keys & other  # the extraction is part of every cell's key


def test_a_config_maps_the_poles_its_scans_show(tmp_path):
    out = tmp_path / "out"
    assert run_experiment(load_config(_write(tmp_path, POLES)), out, console=Console(file=open(os.devnull, "w"))) == 0
    metrics = json.loads(next((out / "runs").glob("*/ekf_slam/*/metrics.json")).read_text())["metrics"]
    # 44 poles in the field; the lap sees most of them: mapped within 0.2 m RMS, few duplicates
    assert metrics["map"]["matched"] >= 40 and metrics["map"]["rmse"] < 0.2 and metrics["map"]["spurious"] <= 4
    assert metrics["ate"]["rmse"] < 0.2
