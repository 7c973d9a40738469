"""Fixed-lag localization smoother on sim:localization: equals the EKF online, better smoothed, robust GPS."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydantic import ValidationError

gtsam = pytest.importorskip("gtsam")

from slamarena.datasets.geometry import interpolate_poses, wrap_angle  # noqa: E402
from slamarena.datasets.sequence import Gps, Heading  # noqa: E402
from slamarena.datasets.sim.localization import simulate  # noqa: E402
from slamarena.estimators.ekf_localizer import EKFLocalizer  # noqa: E402
from slamarena.estimators.gtsam_smoother import FixedLagLocalizer  # noqa: E402
from slamarena.estimators.gtsam_smoother.graph import OptimizationError  # noqa: E402
from slamarena.estimators.gtsam_smoother.problem import PoseChainParams  # noqa: E402


@pytest.fixture(scope="module")
def seq():
    return simulate(duration=20.0, seed=1)


def _rmse(seq, t, poses):
    truth = interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, np.minimum(t, seq.ground_truth.t[-1]))
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


@pytest.fixture(scope="module")
def online(seq):
    return FixedLagLocalizer(output="online").run(seq)


def test_online_output_equals_the_ekf_with_the_same_noise(seq, online):
    """Same inputs, same noise (EKF with the sequence's noise and no extra Q): the smoother's estimate
    right after each update is the filter's, poses and world-frame covariances."""
    ekf = EKFLocalizer(
        Q=(0.0, 0.0, 0.0), use_sequence_noise=True, gate_confidence=1.0, initial_cov=(1e-6, 1e-6, 1e-6)
    ).run(seq)
    last = np.r_[ekf.t[1:] != ekf.t[:-1], True]  # the EKF's pose after all events of a stamp
    t, poses, cov = ekf.t[last], ekf.poses[last], ekf.pose_cov[last]
    k = np.searchsorted(t, online.t)
    assert np.all(np.abs(t[np.minimum(k, len(t) - 1)] - online.t) < 1e-9)
    d = online.poses - poses[k]
    d[:, 2] = wrap_angle(d[:, 2])
    assert np.abs(d).max() < 2e-3
    ratio = np.diagonal(online.pose_cov, axis1=1, axis2=2)[10:] / np.diagonal(cov[k], axis1=1, axis2=2)[10:]
    np.testing.assert_allclose(np.median(ratio, axis=0), 1.0, atol=0.02)
    assert np.all((ratio > 0.7) & (ratio < 1.3))
    assert online.meta["params"] == FixedLagLocalizer.Params(output="online").canonical()


def test_smoothed_output_beats_online_and_is_consistent(seq, online):
    smoothed = FixedLagLocalizer(lag=1.0).run(seq)
    np.testing.assert_allclose(smoothed.diagnostics["online_poses"], online.poses, atol=1e-9)
    assert _rmse(seq, smoothed.t, smoothed.poses) < 0.8 * _rmse(seq, online.t, online.poses)
    truth = interpolate_poses(
        seq.ground_truth.t, seq.ground_truth.poses, np.minimum(smoothed.t, seq.ground_truth.t[-1])
    )
    e = smoothed.poses - truth
    e[:, 2] = wrap_angle(e[:, 2])
    nees = np.einsum("ki,ki->k", e, np.linalg.solve(smoothed.pose_cov, e[..., None])[..., 0])
    # the simulator's twist_cov summarises a time-correlated input error as white noise: consistent to a factor ~2
    assert 1.0 < nees.mean() < 6.0
    assert smoothed.step_time.shape == smoothed.t.shape


def test_robust_gps_kernel_resists_outliers():
    seq = simulate(duration=20.0, seed=2, gps_outlier_fraction=0.1, gps_outlier_magnitude=5.0)
    plain = FixedLagLocalizer(output="online").run(seq)
    robust = FixedLagLocalizer(output="online", robust="cauchy").run(seq)
    assert _rmse(seq, robust.t, robust.poses) < 0.5 * _rmse(seq, plain.t, plain.poses)


def test_nonfinite_and_absurd_gps_and_yaw_are_rejected_and_counted(seq, online):
    xy = seq.gps.xy.copy()
    xy[[3, 17, 40]] = [[np.nan, 0.0], [np.nan, np.nan], [1e300, 0.0]]  # 1e300 m: finite, but its square is not
    yaw = seq.heading.yaw.copy()
    yaw[[5, 9]] = [np.inf, -1e300]
    bad = dataclasses.replace(seq, gps=Gps(t=seq.gps.t, xy=xy), heading=Heading(t=seq.heading.t, yaw=yaw))
    est = FixedLagLocalizer(output="online").run(bad)
    assert est.diagnostics["rejected_nonfinite_gps"] == 3 and est.diagnostics["rejected_nonfinite_heading"] == 2
    assert np.all(np.isfinite(est.poses)) and _rmse(bad, est.t, est.poses) < 2 * _rmse(seq, online.t, online.poses)


def test_an_indeterminate_system_is_an_optimization_error_naming_the_update(seq):
    """GTSAM's raw RuntimeError from the smoother's iSAM2 becomes OptimizationError with the update, its time and the
    variable GTSAM names (a between factor with lateral variance 1e-12 of its largest: the Euler model has no lateral noise)."""
    with pytest.raises(
        OptimizationError,
        match=r"fixed-lag update 1 \(t = 0\.02 s\): GTSAM: Indeterminate linear system .* variable x0",
    ):
        FixedLagLocalizer(regularisation=1e-12).run(seq)


@pytest.mark.parametrize("params", [dict(lag=0.0), dict(output="delayed"), dict(robust="l1"), dict(prior_sigma=[1.0])])
def test_bad_config_is_rejected(params):
    with pytest.raises(ValueError, match=next(iter(params))):
        FixedLagLocalizer(**params)


def test_parameters_are_one_model():
    with pytest.raises(ValidationError, match="yaw_var"):
        FixedLagLocalizer(yaw_var=-1.0)
    with pytest.raises(ValidationError, match="gps_sigma"):
        FixedLagLocalizer(gps_sigma=1.0)  # a misspelt parameter is an error, never ignored
    given = dict(lag=0.5, output="online", gps_cov=[0.04, 0.09], robust="huber")
    assert FixedLagLocalizer(FixedLagLocalizer.Params(**given)).params == FixedLagLocalizer(**given).params
    made = FixedLagLocalizer(**given)
    assert made.params.gps_cov == [[0.04, 0.0], [0.0, 0.09]]
    assert FixedLagLocalizer(made.params.canonical()).params == made.params
    # the pose chain's fields are shared with the landmark smoothers; only the motion model's default differs (the EKF localizer's)
    chain = {k: getattr(made.params, k) for k in PoseChainParams.model_fields}
    assert chain == {**dict(PoseChainParams()), "motion_model": "euler"}
