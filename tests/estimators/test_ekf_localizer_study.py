"""The findings of research/notebook/2026-11-21-ekf-localizer-studies.md as behaviour, at one seed (fast).

The studies' tables are the shipped configs ``localizer_q_unit`` (study 1) and ``gps_sweep`` (study 5), whose claims
are checked on every run of them (``slamarena run``, ``slamarena results``), and ``research/scripts/ekf_localizer_studies.py``
for the tables a config cannot express (a sequence without its IMU, noise taken from another run, a drawn initial
error). Here each finding is pinned on seed 0, its bound set from the value measured on 2026-11-28 (in the comment).
ATE is without alignment (GPS fixes the frame).
"""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.estimators.ekf_localizer import EKFLocalizer
from slamarena.experiments.config import load_config
from slamarena.experiments.metrics.consistency import nees
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def _ate(est, seq) -> dict:
    return ate(est, reference_of(seq), ATEParams(align="none"))[0]


def _sigma_and_error_at(est, seq, t: float) -> tuple[float, float]:
    """The filter's position σ (√trace of the xy covariance) and its actual error at the last pose before ``t``."""
    truth = reference_of(seq)
    end = np.flatnonzero(est.t < t)[-1]
    k = np.searchsorted(truth.t, est.t[end] - 1e-9)
    return float(np.sqrt(np.trace(est.pose_cov[end, :2, :2]))), float(
        np.linalg.norm(est.poses[end, :2] - truth.poses[k, :2])
    )


def test_the_unit_of_q_shows_in_the_covariance_at_the_end_of_an_outage():
    """Study 1 (its other columns are the config ``localizer_q_unit``): after 20 s without GPS the per-step reading of
    the notes' Q claims metres for a few centimetres of error, the per-second reading a fraction of a metre, the filter
    told the simulator's noise what it has. Measured: σ/error 63, 8.6 and 1.01 (error 7.1, 7.4, 7.0 cm)."""
    config = load_config("localizer_q_unit")
    seq = datasets.load("sim:localization", seed=0, **config.datasets[0].params)
    ratio = {}
    for method in config.estimators:
        sigma, error = _sigma_and_error_at(EKFLocalizer(**method.params).run(seq), seq, 40.0)
        assert 0.05 < error < 0.09, (method.label, error)
        ratio[method.label] = sigma / error
    assert ratio["notes_per_step"] > 50
    assert 6 < ratio["notes_per_second"] < 12
    assert 0.8 < ratio["true_noise"] < 1.25


def test_the_imu_yaw_update_divides_the_heading_error_with_slow_gps():
    """Study 4: GPS at 1 Hz, cmd_vel, the simulator's noise; without the IMU the heading is observable only through the
    GPS track. Measured: heading RMSE 0.0265 rad without against 0.0095 with (×2.79), ATE 2.43 against 1.66 cm (×1.47)."""
    seq = datasets.load("sim:localization", duration=60.0, gps_rate=1.0, imu_rate=50.0, seed=0)
    with_imu = _ate(EKFLocalizer(Q=0.0, use_sequence_noise=True).run(seq), seq)
    without = _ate(
        EKFLocalizer(Q=0.0, use_sequence_noise=True).run(type(seq)(**{**seq.__dict__, "heading": None})), seq
    )
    assert without["heading_rmse"] > 2.5 * with_imu["heading_rmse"]
    assert without["rmse"] > 1.3 * with_imu["rmse"]


def _told_the_slip_free_noise(source: str, **sim) -> tuple:
    """A run predicting from ``source``, told the input noise the simulator states for the slip-free run (study 3)."""
    clean = datasets.load(
        "sim:localization", motion_source=source, seed=0, **{k: v for k, v in sim.items() if k != "slip"}
    )
    seq = datasets.load("sim:localization", motion_source=source, seed=0, **sim)
    noise = dict(twist_cov=clean.noise.twist_cov.tolist(), R_gps=seq.noise.gps_cov.tolist(), R_imu=seq.noise.yaw_var)
    return EKFLocalizer(Q=0.0, **noise).run(seq), seq


def test_odometry_beats_cmd_vel_without_slip():
    """Study 3: predicting from wheel odometry halves the position error and divides the heading error by about three.
    Measured: ATE 0.50 / 1.05 cm (×0.48), heading 0.0049 / 0.0135 rad (×0.37)."""
    runs = {
        source: _ate(*_told_the_slip_free_noise(source, duration=60.0, imu_rate=10.0))
        for source in ("odometry", "cmd_vel")
    }
    assert runs["odometry"]["rmse"] < 0.55 * runs["cmd_vel"]["rmse"]
    assert runs["odometry"]["heading_rmse"] < 0.45 * runs["cmd_vel"]["heading_rmse"]


def test_odometry_does_not_see_wheel_slip_and_claims_centimetres_while_it_drifts_metres():
    """Study 3: both wheels at 80 % ground speed (20–40 s), GPS lost 15–45 s: odometry drifts by metres while its
    covariance claims the slip-free noise. Measured: max error 3.71 m, RMSE 1.69 m, mean NEES 2.0e4."""
    est, seq = _told_the_slip_free_noise(
        "odometry", duration=60.0, imu_rate=10.0, gps_outages=[(15.0, 45.0)], slip=[(20.0, 40.0, 0.8)]
    )
    assert _ate(est, seq)["max"] > 3.0
    assert nees(est, reference_of(seq))[0]["mean"] > 1e4


@pytest.mark.slow
@pytest.mark.parametrize("name", ["localizer_q_unit", "gps_sweep"])
def test_the_shipped_studies_claims_hold(tmp_path, name):
    """The whole config (about a minute, and three on a loaded machine); the runner checks its claims: exit 0 only if
    every cell ran and every claim holds."""
    from slamarena.experiments.runner import run_experiment

    assert run_experiment(load_config(name), tmp_path, jobs=2) == 0


@pytest.mark.slow
def test_the_filter_is_consistent_with_odometry_and_not_with_cmd_vel():
    """Study 2: 50 seeds × 10 s, GPS 5 Hz, IMU 10 Hz, the simulator's stated noise, the initial error drawn from P0: with
    white encoder noise (odometry) the 50-run NEES average stays in its χ² band; with cmd_vel's time-correlated
    actuator error it does not. Measured (ARC): 98.0 % and 72.4 % of the steps in band."""
    from slamarena.datasets.sequence import Sequence
    from slamarena.experiments.metrics.consistency import monte_carlo

    P0 = np.array([1e-4, 1e-4, 1e-3])
    in_band = {}
    for source in ("odometry", "cmd_vel"):
        runs = []
        for seed in range(50):
            seq = datasets.load("sim:localization", duration=10.0, imu_rate=10.0, motion_source=source, seed=seed)
            start = seq.start_pose + np.sqrt(P0) * np.random.default_rng(10_000 + seed).standard_normal(3)
            seq = Sequence(**{**seq.__dict__, "initial_pose": start})
            est = EKFLocalizer(motion_model="arc", Q=0.0, use_sequence_noise=True, initial_cov=P0.tolist()).run(seq)
            series = nees(est, reference_of(seq))[1]
            runs.append((series["t"], series["nees"]))
        in_band[source] = float(monte_carlo(runs, 3)["in_band"])
    assert in_band["odometry"] >= 0.95
    assert in_band["cmd_vel"] < 0.8


@pytest.mark.slow
@pytest.mark.realdata
def test_mrclam_localization_against_the_surveyed_map_beats_dead_reckoning():
    """MRCLAM Dataset 6, every robot (research/notebook/2026-11-21-ekf-localizer-real-data.md): odometry prediction and
    range-bearing updates to the surveyed landmarks against the same filter fed only the odometry. Measured
    2026-11-28: EKF ATE 0.189/0.240/0.226/0.303/0.212 m (robots 1–5), at most 0.166 of dead reckoning's (robot 4)."""
    from checks import load_staged

    filter_params = _mrclam_filter()
    for robot in range(1, 6):
        seq = load_staged(f"utias:6/robot{robot}")
        est = _ate(EKFLocalizer(**filter_params).run(seq), seq)
        dead = _ate(EKFLocalizer(**filter_params).run(type(seq)(**{**seq.__dict__, "range_bearing": None})), seq)
        assert est["rmse"] < 0.35 * dead["rmse"] and est["rmse"] < 0.35, robot


def _mrclam_filter() -> dict:
    """``MRCLAM_FILTER`` of research/scripts/ekf_localizer_studies.py (its derivation: the real-data notebook)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "research" / "scripts" / "ekf_localizer_studies.py"
    spec = importlib.util.spec_from_file_location("ekf_localizer_studies", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.MRCLAM_FILTER
