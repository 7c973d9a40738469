"""Monte Carlo consistency of EKF-SLAM (slow: ≈ 10 min on 2 cores; `pytest -m slow`).

The regime-2 study of research/ekf_slam.md: 30 seeds, 4 laps, more heading noise. FEJ, OC and the
ideal EKF must stay inside the 95 % band of the 30-run average NEES; the standard EKF must end
above FEJ (the inconsistency the study reports)."""
from __future__ import annotations

import numpy as np
import pytest

SIM = {"n_landmarks": 30, "sigma_omega": 0.1, "sigma_bearing": 0.0349}


@pytest.mark.slow
def test_fej_oc_and_ideal_are_consistent_and_standard_is_not():
    from slamarena.experiments.ekf_slam_study import consistency

    res = consistency(seeds=30, laps=4, sim=SIM, variants=["standard", "FEJ", "OC", "ideal"])
    for name in ("FEJ", "OC", "ideal"):
        assert res[name]["in_band"] > 0.9
        assert abs(res[name]["mean"].mean() - 3.0) < 0.3
    tail = lambda mc: mc["mean"][mc["t"] >= mc["t"][-1] - 0.1 * (mc["t"][-1] - mc["t"][0])].mean()
    assert tail(res["standard"]) > tail(res["FEJ"]) + 0.5
    assert res["standard"]["in_band"] < res["FEJ"]["in_band"]
    assert np.all(np.isfinite(res["standard"]["mean"]))
