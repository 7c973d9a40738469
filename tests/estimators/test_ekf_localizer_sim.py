"""EKF localizer on ``sim:localization``: Monte Carlo consistency, outliers, outages.

Consistency needs a filter whose model is the simulator's: wheel odometry as the input (its
error is white encoder noise; cmd_vel errors are time-correlated actuator lag, see
research/method/ekf_localizer.md), the exact ARC step, the simulator's stated noise
(``use_sequence_noise``) and no extra Q, and initial estimates drawn from the initial
covariance they claim.
"""

from __future__ import annotations

import numpy as np

from slamarena import datasets
from slamarena.datasets.sequence import Sequence
from slamarena.estimators.ekf_localizer import EKFLocalizer
from slamarena.experiments.metrics.consistency import chi2_band, monte_carlo, nees
from slamarena.experiments.metrics.reference import reference_of

P0 = np.array([1e-4, 1e-4, 1e-3])


def _consistent_filter(**kw) -> EKFLocalizer:
    return EKFLocalizer(motion_model="arc", Q=0.0, use_sequence_noise=True, initial_cov=P0.tolist(), **kw)


def _perturbed_start(seq: Sequence, seed: int) -> Sequence:
    rng = np.random.default_rng(10_000 + seed)
    return Sequence(**{**seq.__dict__, "initial_pose": seq.start_pose + np.sqrt(P0) * rng.standard_normal(3)})


def test_monte_carlo_nees_and_nis_are_consistent():
    """50 seeds × 10 s: the seed-averaged NEES stays in the χ²(150)/50 95% band on ≥ 90% of the
    steps; every sensor's NIS averages its dimension."""
    runs, nis = [], {"gps": [], "imu": []}
    for seed in range(50):
        seq = datasets.load("sim:localization", duration=10.0, imu_rate=10.0, motion_source="odometry", seed=seed)
        est = _consistent_filter().run(_perturbed_start(seq, seed))
        _, series = nees(est, reference_of(seq))
        runs.append((series["t"], series["nees"]))
        for sensor in nis:
            assert int(est.diagnostics[f"nis_dim_{sensor}"]) == {"gps": 2, "imu": 1}[sensor]
            nis[sensor].append(est.diagnostics[f"nis_{sensor}"])
    mc = monte_carlo(runs, 3)
    assert mc["runs"] == 50 and mc["t"].size > 500
    assert mc["in_band"] >= 0.90, f"average NEES in band on {mc['in_band']:.1%} of steps"
    assert 0.85 < mc["mean"].mean() / 3.0 < 1.15
    for sensor, dim in (("gps", 2), ("imu", 1)):
        values = np.concatenate(nis[sensor])
        lo, hi = chi2_band(dim, values.size)  # band of the mean of all NIS values
        assert lo * 0.95 <= values.mean() <= hi * 1.05, f"{sensor}: mean NIS {values.mean():.3f} for dimension {dim}"


def test_sim_gps_outlier_burst_does_not_move_the_estimate():
    """10 m spikes on 2% of the fixes: every spike is gated out; the error stays at the GPS-noise level
    of the same run without spikes (same seed: same clean fixes), and the only difference — the
    drift over the gap a dropped fix leaves — is a few GPS σ, where the ungated filter jumps metres."""
    kw = dict(duration=40.0, imu_rate=10.0, seed=3)
    clean = datasets.load("sim:localization", **kw)
    spiked = datasets.load("sim:localization", gps_outlier_fraction=0.02, gps_outlier_magnitude=10.0, **kw)
    n_spikes = len(spiked.meta["gps_outlier_index"])
    assert n_spikes >= 2
    a = EKFLocalizer(use_sequence_noise=True, Q=0.0).run(clean)
    b = EKFLocalizer(use_sequence_noise=True, Q=0.0).run(spiked)
    assert b.meta["rejected"]["gps"]["gate"] == n_spikes
    assert a.meta["rejected"]["gps"].get("gate", 0) == 0
    sigma = clean.meta["gps_sigma"]
    shift = np.linalg.norm(b.poses[:, :2] - a.poses[:, :2], axis=1)
    assert shift.max() < 3 * sigma
    ref = reference_of(clean)
    k = np.searchsorted(ref.t, a.t - 1e-9)
    err_a = np.linalg.norm(a.poses[:, :2] - ref.poses[k, :2], axis=1)
    err_b = np.linalg.norm(b.poses[:, :2] - ref.poses[k, :2], axis=1)
    assert err_b.max() < err_a.max() + sigma
    ungated = EKFLocalizer(use_sequence_noise=True, Q=0.0, gate_confidence=1.0).run(spiked)
    assert np.linalg.norm(ungated.poses[:, :2] - a.poses[:, :2], axis=1).max() > 1.0


def test_sim_recovery_after_a_20_s_outage():
    seq = datasets.load(
        "sim:localization", duration=45.0, imu_rate=10.0, motion_source="odometry", gps_outages=[(15.0, 35.0)], seed=4
    )
    est = _consistent_filter().run(seq)
    t = est.t
    pos_sd = np.sqrt(est.pose_cov[:, 0, 0] + est.pose_cov[:, 1, 1])
    truth = reference_of(seq)
    err = np.linalg.norm(
        est.poses[:, :2] - np.array([truth.poses[np.searchsorted(truth.t, s - 1e-9)] for s in t])[:, :2], axis=1
    )
    before, during_end, after = (t > 10) & (t < 15), (t > 34) & (t < 35), t > 36
    assert pos_sd[during_end].min() > 5 * pos_sd[before].max()  # covariance grows through the outage
    assert err[during_end].max() < 3 * pos_sd[during_end].max()  # ...and covers the drift
    assert err[after].max() < 0.03 and pos_sd[after].max() < 0.02  # back to GPS accuracy
    assert est.meta["rejected"]["gps"].get("gate", 0) == 0
