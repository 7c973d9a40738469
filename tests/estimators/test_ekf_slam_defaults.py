"""EKF-SLAM's defaults as a user gets them (``slamarena.create("ekf_slam", use_ids=False)``): the twist noise when
nothing states one, and the defaults on the staged real data of issue 33 (skipped when it is not staged;
research/notebook/2026-11-28-ekf-defaults.md, research/notebook/2026-11-28-ekf-adaptive-noise.md)."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged

import slamarena
from slamarena.datasets.sequence import Noise, Sequence
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.models import UNSTATED_TWIST_COV


def test_the_twist_noise_nothing_states_is_mrclams_identified_one():
    """No parameter, no Noise.twist_cov: M = MRCLAM's identified twist noise (σ_v 0.108 m/s, σ_ω 0.417 rad/s per row);
    a stated one wins, a parameter wins over both."""
    ekf = EKFSLAM()
    ekf.reset(Sequence(name="bare", noise=Noise()))
    np.testing.assert_array_equal(ekf.M, np.diag([0.0117624, 0.174]))
    np.testing.assert_array_equal(ekf.M, UNSTATED_TWIST_COV)
    ekf.reset(Sequence(name="stated", noise=Noise(twist_cov=np.diag([0.2, 0.3]))))
    np.testing.assert_array_equal(ekf.M, np.diag([0.2, 0.3]))
    given = EKFSLAM(twist_cov=[0.5, 0.6])
    given.reset(Sequence(name="stated", noise=Noise(twist_cov=np.diag([0.2, 0.3]))))
    np.testing.assert_array_equal(given.M, np.diag([0.5, 0.6]))


def test_fastslam_falls_back_to_the_same_twist_noise_as_ekf_slam():
    """One fallback for the landmark filters (estimators.models.UNSTATED_TWIST_COV): FastSLAM on a sequence that states no
    twist noise takes MRCLAM's identified one, as EKF-SLAM does (it took σ_v 0.1, σ_ω 0.05 before); stated noise and a
    parameter win as for EKF-SLAM."""
    bare = Sequence(name="bare", noise=Noise())
    fs, ekf = FastSLAM(particles=3), EKFSLAM()
    fs.reset(bare)
    ekf.reset(bare)
    np.testing.assert_array_equal(fs.M_twist, np.diag([0.0117624, 0.174]))
    np.testing.assert_array_equal(fs.M_twist, ekf.M)
    fs.reset(Sequence(name="stated", noise=Noise(twist_cov=np.diag([0.2, 0.3]))))
    np.testing.assert_array_equal(fs.M_twist, np.diag([0.2, 0.3]))
    given = FastSLAM(particles=3, twist_cov=[[0.5, 0.0], [0.0, 0.6]])
    given.reset(bare)
    np.testing.assert_array_equal(given.M_twist, np.diag([0.5, 0.6]))


def test_the_defaults_map_every_car_park_beacon():
    """The car park's extracted beacons, every default, ids withheld: all 15 surveyed beacons mapped within 0.5 m RMS,
    the path within 1 m of the GPS and 3× better than dead reckoning. Not asserted: spurious landmarks (the defaults make
    4, the returns of a moving reflective object; tentative landmarks remove them and are not a default, because on
    Victoria Park they break the working configuration)."""
    from slamarena.experiments.metrics import reference_of
    from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
    from slamarena.experiments.metrics.trajectory import ATEParams, ate
    from slamarena.mapping.landmark_extraction import landmark_sequence

    seq = landmark_sequence(load_staged("carpark"))
    ref = reference_of(seq)
    score = ATEParams(align="se2", max_gap=0.25)
    est = slamarena.create("ekf_slam", use_ids=False).run(seq)
    dead = slamarena.create("dead_reckoning").run(seq)
    m, _ = landmark_error(est, ref, MapParams(by="nearest", max_distance=2.0, max_gap=0.25))
    assert m["matched"] == 15 and m["rmse"] <= 0.5
    ate_ekf, ate_dead = ate(est, ref, score)[0]["rmse"], ate(dead, ref, score)[0]["rmse"]
    assert ate_ekf <= 1.0 and 3 * ate_ekf <= ate_dead


ISAM2_END = np.array([-13.99, 0.53])  # Victoria Park: iSAM2's final position with the file's ids and noise


@pytest.mark.xfail(
    strict=True,
    reason="issue 33's Victoria Park goal is not met by the defaults: with the file's stated noise they make 437 "
    "landmarks and end 192 m from iSAM2 (research/notebook/2026-11-28-ekf-defaults.md); self_identify reaches it but "
    "is not the default (it maps the car park's moving object and duplicates: "
    "research/notebook/2026-11-28-ekf-adaptive-noise.md)",
)
def test_the_defaults_map_victoria_parks_trees():
    """Victoria Park, every default, ids withheld: 151 ± 15 landmarks, the goal of issue 33 (an expected failure: it
    passes, and so fails as strict, the day the defaults reach it)."""
    seq = load_staged("victoria_park")
    est = slamarena.create("ekf_slam", use_ids=False).run(seq)
    assert abs(len(est.landmark_ids) - 151) <= 15


@pytest.mark.slow  # ≈ 5 min of CPU: the file's noise is rejected and 19 walks are run (self_identification)
def test_self_identification_maps_victoria_parks_trees():
    """Victoria Park, ids withheld, every default but ``self_identify=True``: the file's noise is rejected by the
    innovations and the most likely scales (Q × 64, R / 64) give 151 ± 15 landmarks and a final position within 5 m of
    iSAM2's with the ids (research/notebook/2026-11-28-ekf-adaptive-noise.md: 154 landmarks, 1.3 m)."""
    seq = load_staged("victoria_park")
    est = slamarena.create("ekf_slam", use_ids=False, self_identify=True).run(seq)
    assert est.meta["noise_identification"]["rejected"]
    assert abs(len(est.landmark_ids) - 151) <= 15
    assert np.linalg.norm(est.poses[-1, :2] - ISAM2_END) <= 5.0
