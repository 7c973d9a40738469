"""Monte Carlo consistency of EKF-SLAM: the claims of research/results.md, section 2, on the shipped config
``consistency`` at reduced size — its hard world only, the standard, FEJ and ideal filters, its 30 seeds (slow: ≈ 10 min
on 2 quiet cores; `pytest -m slow`).

FEJ, OC and the ideal EKF must stay inside the 95 % band of the 30-run average NEES; the standard EKF must end above FEJ
and spend fewer stamps in the band (the inconsistency the study reports)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest


@pytest.mark.slow
def test_fej_oc_and_ideal_are_consistent_and_standard_is_not(tmp_path):
    from slamarena.experiments.config import load_config
    from slamarena.experiments.runner import run_experiment

    config = load_config("consistency").reduced(
        datasets=["hard"], estimators=["ekf_slam", "ekf_slam_fej", "ekf_slam_oc", "ekf_slam_ideal"]
    )
    assert run_experiment(config, tmp_path, jobs=2) == 0
    mc = pd.read_csv(tmp_path / "tables" / "monte_carlo.csv").query("statistic == 'nees'").set_index("estimator")
    assert set(mc.index) == {"ekf_slam", "ekf_slam_fej", "ekf_slam_oc", "ekf_slam_ideal"} and (mc["runs"] == 30).all()
    for name in ("ekf_slam_fej", "ekf_slam_oc", "ekf_slam_ideal"):
        assert mc.at[name, "in_band"] > 0.9
        assert abs(mc.at[name, "mean_over_dof"] - 1.0) < 0.1
    assert mc.at["ekf_slam", "late_over_dof"] > mc.at["ekf_slam_fej", "late_over_dof"] + 0.5 / 3
    assert mc.at["ekf_slam", "in_band"] < mc.at["ekf_slam_fej", "in_band"]
    assert np.isfinite(mc["mean_over_dof"]).all()
