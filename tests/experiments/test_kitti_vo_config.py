"""The shipped kitti_vo config runs through the runner on a prefix of KITTI 00: a 3-D estimate per cell, the 3-D metrics
in the summary (staged data; skips without it)."""

from __future__ import annotations

import pandas as pd
import pytest

from slamarena.experiments.config import ExperimentConfig, load_config
from slamarena.experiments.runner import run_experiment

pytestmark = pytest.mark.realdata


def test_kitti_vo_on_a_prefix(tmp_path):
    from slamarena.datasets.registry import resolve

    if not resolve("kitti:00").present():
        pytest.skip("kitti:00 is not under any data root (set SLAMARENA_DATA)")
    raw = (
        load_config("kitti_vo")
        .reduced(datasets=["kitti00_stereo", "kitti00_mono"])
        .model_dump(mode="json", exclude_unset=True)
    )
    for dataset in raw["datasets"]:
        dataset["params"]["frames"] = 12 if dataset["label"] == "kitti00_stereo" else 25
    raw["estimators"] = [e for e in raw["estimators"] if e.get("label") is None]  # stereo_vo, mono_vo
    raw["metrics"]["kitti_rel"] = {"lengths": [5.0], "step": 1}
    config = ExperimentConfig.model_validate(raw)
    from slamarena.paper_figures.make import make_all

    assert run_experiment(config, tmp_path, jobs=1, make_figures=make_all) == 0
    summary = pd.read_csv(tmp_path / "summary.csv").set_index("estimator")
    stereo, mono = summary.loc["stereo_vo"], summary.loc["mono_vo"]
    assert stereo["ate3d.path_m"] == pytest.approx(9.45, abs=0.1)  # 11 steps of 0.86 m
    assert stereo["ate3d.percent"] < 5 and stereo["kitti_rel.segments"] > 0
    assert mono["ate3d.sim3_percent"] < 5 and mono["ate3d.sim3_scale"] > 0
    assert stereo["cost.step_total"] > 0 and stereo["cost.steps"] == 12
    for stem in ("vo_top_view", "vo_error_over_distance", "vo_tracked_features"):  # figures: [vo]
        assert (tmp_path / "figures" / f"{stem}.png").stat().st_size > 1000, stem
