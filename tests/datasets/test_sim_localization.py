"""sim:localization — determinism, sensor statistics, outages/outliers, actuator lag, odometry and slip."""

from __future__ import annotations

import math

import numpy as np
import pytest
from checks import assert_dead_reckoning_consistent, assert_gaussian, assert_rejected_naming
from scipy import stats

from slamarena import datasets
from slamarena.datasets.geometry import interpolate_poses, wrap_angle
from slamarena.datasets.sim.localization import LocalizationWorldParams, first_order_response, simulate
from slamarena.estimators.models import ARC


def row_twist(seq) -> tuple[np.ndarray, np.ndarray]:
    """Mean true (v, ω) of each row: arc length and heading change of the truth over the row."""
    gt = seq.ground_truth.poses
    T = seq.motion.dt
    phi = wrap_angle(np.diff(gt[:, 2]))
    mid = gt[:-1, 2] + phi / 2
    step = np.diff(gt[:, :2], axis=0)
    chord = step[:, 0] * np.cos(mid) + step[:, 1] * np.sin(mid)  # signed: backwards is negative
    return chord / (T * np.sinc(phi / 2 / np.pi)), phi / T


@pytest.fixture(scope="module")
def seq():
    return simulate(seed=11)


def test_determinism_and_shared_world_across_motion_sources():
    a, b = simulate(seed=2), simulate(seed=2)
    np.testing.assert_array_equal(a.motion.v, b.motion.v)
    np.testing.assert_array_equal(a.gps.xy, b.gps.xy)
    odo = simulate(seed=2, motion_source="odometry")
    np.testing.assert_array_equal(a.ground_truth.poses, odo.ground_truth.poses)
    np.testing.assert_array_equal(a.gps.xy, odo.gps.xy)
    np.testing.assert_array_equal(a.heading.yaw, odo.heading.yaw)
    assert not np.array_equal(a.motion.v, odo.motion.v)
    assert not np.array_equal(a.ground_truth.poses, simulate(seed=3).ground_truth.poses)


def test_rates_stamps_and_stated_noise(seq):
    s = datasets.load("sim:localization", duration=10.0, gps_rate=2.0, imu_rate=25.0)
    assert len(s.motion) == 500 and np.allclose(s.motion.dt, 0.02)
    np.testing.assert_allclose(np.diff(s.gps.t), 0.5)
    np.testing.assert_allclose(np.diff(s.heading.t), 0.04)
    assert len(s.gps) == 21 and len(s.heading) == 251
    assert len(s.ground_truth) == len(s.motion) + 1
    np.testing.assert_allclose(seq.noise.gps_cov, 1e-4 * np.eye(2))
    assert seq.noise.yaw_var == 1e-3
    np.testing.assert_allclose(seq.noise.twist_cov, np.asarray(seq.meta["twist_psd"]) * 50.0)


def test_gps_and_imu_noise_statistics(seq):
    truth_gps = interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, seq.gps.t)
    e = seq.gps.xy - truth_gps[:, :2]
    assert np.abs(e).max() < 0.1  # within-row interpolation error is far below the 1 cm noise
    assert_gaussian(e[:, 0], 0.01)
    assert_gaussian(e[:, 1], 0.01)
    truth_imu = interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, seq.heading.t)
    assert np.all(np.abs(seq.heading.yaw) <= np.pi)
    assert_gaussian(wrap_angle(seq.heading.yaw - truth_imu[:, 2]), math.sqrt(1e-3))


def test_heading_is_counter_clockwise_from_east():
    s = simulate(
        seed=0,
        duration=20.0,
        imu_var=1e-8,
        v_amplitude=0.0,
        omega_amplitude=0.0,
        ramp=0.0,
        actuator_sigma=0.0,
        start=(0.0, 0.0, math.pi / 2),
    )
    np.testing.assert_allclose(s.heading.yaw, math.pi / 2, atol=1e-3)  # driving straight north
    assert s.gps.xy[-1, 1] > 19.0 and abs(s.gps.xy[-1, 0]) < 0.1


def test_gps_outages_and_outliers():
    s = simulate(seed=4, gps_outages=[(10.0, 20.0), (50.0, 52.5)], gps_outlier_fraction=0.1, gps_outlier_magnitude=5.0)
    t = s.gps.t
    assert not np.any((t >= 10.0) & (t < 20.0)) and not np.any((t >= 50.0) & (t < 52.5))
    assert len(s.gps) == 601 - 50 - 13
    idx = np.array(s.meta["gps_outlier_index"])
    n = len(s.gps)
    assert stats.binom.ppf(1e-4, n, 0.1) <= idx.size <= stats.binom.ppf(1 - 1e-4, n, 0.1)
    truth = interpolate_poses(s.ground_truth.t, s.ground_truth.poses, t)[:, :2]
    err = np.hypot(*(s.gps.xy - truth).T)
    np.testing.assert_allclose(err[idx], 5.0, atol=0.06)
    assert np.delete(err, idx).max() < 0.06


def test_odometry_noise_matches_the_encoder_model():
    s = simulate(seed=5, motion_source="odometry")
    v, w = row_twist(s)
    T, b, sig = 0.02, 0.5, 2e-4
    assert_gaussian(s.motion.v - v, sig / (math.sqrt(2) * T))
    assert_gaussian(s.motion.omega - w, math.sqrt(2) * sig / (b * T))
    # the stated per-row covariance is the measured error per second: χ²(120 windows) around the model
    lo, hi = stats.chi2.ppf([1e-4, 1 - 1e-4], 120) / 120
    ratio = np.diag(s.noise.twist_cov) / np.diag(s.meta["encoder_twist_cov"])
    assert np.all((lo <= ratio) & (ratio <= hi)), ratio


def test_white_actuator_noise_gives_the_stated_cmd_vel_covariance():
    s = simulate(seed=8, actuator_tau=0.0, actuator_sigma=0.05)
    m, b = 10, 0.5
    expected = np.array([0.05**2 / (2 * m), 2 * 0.05**2 / (b * b * m)])  # per row: mean of m white substeps
    lo, hi = stats.chi2.ppf([1e-4, 1 - 1e-4], 120) / 120
    ratio = np.diag(s.noise.twist_cov) / expected
    assert np.all((lo <= ratio) & (ratio <= hi)), ratio


def test_stated_noise_makes_dead_reckoning_consistent():
    """Monte Carlo NEES of the final pose of dead reckoning with Noise.twist_cov: inside the χ² band."""
    assert_dead_reckoning_consistent(simulate(seed=seed, duration=15.0, motion_source="odometry") for seed in range(30))


def test_noiseless_odometry_reproduces_the_truth():
    s = simulate(seed=6, motion_source="odometry", encoder_sigma=0.0)
    poses = ARC.integrate(s.initial_pose, s.motion.v, s.motion.omega, s.motion.dt)
    assert np.abs(poses[:, :2] - s.ground_truth.poses[:, :2]).max() < 1e-3  # within-row twist variation only
    np.testing.assert_allclose(poses[:, 2], s.ground_truth.poses[:, 2], atol=1e-9)


def test_actuator_lag_makes_execution_differ_from_command():
    exact = simulate(seed=1, actuator_tau=0.0, actuator_sigma=0.0, encoder_sigma=0.0)
    lagged = simulate(seed=1, actuator_tau=0.3, actuator_sigma=0.0, encoder_sigma=0.0)
    np.testing.assert_array_equal(exact.motion.v, lagged.motion.v)  # same commands
    replay = ARC.integrate(exact.initial_pose, exact.motion.v, exact.motion.omega, exact.motion.dt)
    np.testing.assert_allclose(replay, exact.ground_truth.poses, atol=1e-9)
    assert np.hypot(*(replay - lagged.ground_truth.poses)[:, :2].T).max() > 0.1
    assert np.trace(lagged.noise.twist_cov) > 10 * np.trace(exact.noise.twist_cov)


def test_slip_is_unseen_by_odometry():
    s = simulate(seed=7, motion_source="odometry", slip=[(30.0, 40.0, 0.5)], encoder_sigma=0.0)
    v, w = row_twist(s)
    inside = (s.motion.t >= 30.0) & (s.motion.t < 40.0)
    np.testing.assert_allclose(v[inside], 0.5 * s.motion.v[inside], rtol=1e-3)
    np.testing.assert_allclose(v[~inside], s.motion.v[~inside], rtol=1e-3, atol=1e-6)
    one_wheel = simulate(seed=7, motion_source="odometry", slip=[(30.0, 40.0, 1.0, 0.5)], encoder_sigma=0.0)
    v1, w1 = row_twist(one_wheel)
    assert np.abs(w1[inside] - one_wheel.motion.omega[inside]).min() > 0.1  # right wheel slips: turns right of odometry


def test_first_order_response_equals_the_literal_recursion(rng):
    u = rng.standard_normal((5000, 2))
    for a in (0.0, 0.3, 0.98, 0.9999):
        w = np.empty((5001, 2))
        w[0] = [1.0, -2.0]
        for n in range(5000):
            w[n + 1] = a * w[n] + u[n]
        np.testing.assert_allclose(first_order_response(u, a, np.array([1.0, -2.0])), w, rtol=1e-9, atol=1e-9)


def test_step_response_of_the_actuator():
    a = math.exp(-0.002 / 0.1)
    w = first_order_response(np.full((500, 1), 1.0 - a), a, np.zeros(1))[:, 0]
    np.testing.assert_allclose(w, 1.0 - np.exp(-np.arange(501) * 0.002 / 0.1), atol=1e-12)


@pytest.mark.parametrize(
    "bad",
    [
        dict(motion_source="imu"),
        dict(cmd_rate=0.0),
        dict(gps_outlier_fraction=1.5),
        dict(gps_outages=[(5.0, 1.0)]),
        dict(slip=[(1.0, 2.0)]),
        dict(slip=[(1.0, 2.0, -0.5)]),
        dict(imu_var=-1.0),
        dict(duration=0.5),
        dict(duration=-30.0),
        dict(start=(0.0, 0.0)),
        dict(substeps=0),
        dict(cmd_rate=0.4, duration=1.0),
        dict(substeps=1, cmd_rate=0.3, duration=10.0),
        dict(seed=-1),
        dict(gps_sigmma=0.1),
        dict(duration=1e12),  # a run beyond the memory available
    ],
)
def test_bad_config_is_rejected_naming_the_field(bad):
    assert_rejected_naming(simulate, **bad)


def test_a_params_model_and_keywords_simulate_alike():
    slip = [(2.0, 3.0, 0.5, 1.0)]
    given = simulate(params=LocalizationWorldParams(duration=5.0, slip=slip, motion_source="odometry", seed=3))
    keywords = datasets.load("sim:localization", duration=5.0, slip=slip, motion_source="odometry", seed=3)
    assert simulate.Params is LocalizationWorldParams and given.meta == keywords.meta
    assert given.meta["slip"] == [[2.0, 3.0, 0.5, 1.0]]
    np.testing.assert_array_equal(given.motion.v, keywords.motion.v)
