"""Landmark-SLAM smoothers on sim:landmarks: accuracy vs dead reckoning, Monte Carlo consistency,
iSAM2 = batch, optimisers, robust kernels, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydantic import ValidationError

gtsam = pytest.importorskip("gtsam")

from checks import assert_covariances_close  # noqa: E402

from slamarena.datasets.geometry import compose, interpolate_poses, wrap_angle  # noqa: E402
from slamarena.datasets.sequence import Increments, RangeBearing  # noqa: E402
from slamarena.datasets.sim.landmarks import simulate  # noqa: E402
from slamarena.estimators import create  # noqa: E402
from slamarena.estimators.gtsam_smoother import BatchSmoother, ISAM2Smoother  # noqa: E402
from slamarena.estimators.gtsam_smoother.graph import L, OptimizationError, OptimizerParams, X, optimize  # noqa: E402
from slamarena.estimators.gtsam_smoother.problem import LandmarkProblemParams, build_problem  # noqa: E402
from slamarena.estimators.models import ARC  # noqa: E402
from slamarena.experiments.metrics.consistency import chi2_band, monte_carlo  # noqa: E402

SIM = dict(n_landmarks=30, laps=1)


def _truth_at(seq, t):
    return interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, np.minimum(t, seq.ground_truth.t[-1]))


def _world_error(poses, truth):
    e = poses - truth
    e[:, 2] = wrap_angle(e[:, 2])
    return e


def _nees(e, P):
    return np.einsum("ki,ki->k", e, np.linalg.solve(P, e[..., None])[..., 0])


@pytest.fixture(scope="module")
def seq():
    return simulate(seed=3, **SIM)


@pytest.fixture(scope="module")
def batch(seq):
    return BatchSmoother().run(seq)


def test_registry_names_construct_the_smoothers():
    assert isinstance(create("gtsam_batch"), BatchSmoother)
    assert isinstance(create("gtsam_isam2", relinearize_skip=1), ISAM2Smoother)


def test_batch_beats_dead_reckoning(seq, batch):
    truth = _truth_at(seq, batch.t)
    dr = build_problem(seq).dead_reckoning()
    rmse = lambda p: np.sqrt(np.mean(np.sum((p[:, :2] - truth[:, :2]) ** 2, axis=1)))  # noqa: E731
    assert rmse(batch.poses) < 0.2 * rmse(dr)
    assert rmse(batch.poses) < 0.15
    true_xy = seq.landmarks.xy[np.searchsorted(seq.landmarks.ids, batch.landmark_ids)]
    assert np.sqrt(np.mean(np.sum((batch.landmarks - true_xy) ** 2, axis=1))) < 0.2
    assert batch.diagnostics["final_error"] < batch.diagnostics["initial_error"]
    assert batch.meta["params"] == BatchSmoother.Params().canonical()
    # ½ χ² of the residuals at the optimum ≈ ½ (measurements − unknowns)
    dof = 2 * len(seq.range_bearing) + 3 * (len(batch.t) - 1) + 3 - 3 * len(batch.t) - 2 * len(batch.landmarks)
    assert 0.5 * chi2_band(dof, 1, 0.999)[0] < batch.diagnostics["final_error"] < 0.5 * chi2_band(dof, 1, 0.999)[1]


def test_batch_monte_carlo_nees_within_chi2_band():
    """10 seeds: pose NEES (world frame, vs the simulator's truth) averaged over the runs lies in the
    χ²(30)/10 band at most steps and at the end; landmark NEES likewise with χ²(20)/10."""
    runs, final, landmark = [], [], []
    for seed in range(10):
        s = simulate(seed=seed, **SIM)
        est = BatchSmoother().run(s)
        eps = _nees(_world_error(est.poses, _truth_at(s, est.t)), est.pose_cov)
        runs.append((est.t, eps))
        final.append(eps[-1])
        true_xy = s.landmarks.xy[np.searchsorted(s.landmarks.ids, est.landmark_ids)]
        landmark.append(_nees(est.landmarks - true_xy, est.landmark_cov)[:20])
    poses = monte_carlo(runs, 3)
    assert poses["in_band"] > 0.75
    lo, hi = chi2_band(3, 10)
    assert lo < np.mean(final) < hi
    lo, hi = chi2_band(2, 10)
    mean_l = np.mean(landmark, axis=0)
    assert np.mean((mean_l > lo) & (mean_l < hi)) > 0.75


def test_isam2_final_equals_batch(seq, batch):
    est = ISAM2Smoother().run(seq)
    np.testing.assert_allclose(est.t, batch.t)
    assert np.abs(_world_error(est.poses, batch.poses)).max() < 1e-6
    np.testing.assert_allclose(est.landmarks, batch.landmarks, atol=1e-6)
    # equal in every direction to 0.1 % of the variance along it (measured: 1e-5 poses, 2e-8 landmarks; 0.15 / 0.03 without
    # the final updates)
    assert_covariances_close(est.pose_cov, batch.pose_cov, rtol=1e-3)
    assert_covariances_close(est.landmark_cov, batch.landmark_cov, rtol=1e-3)
    assert est.step_time.shape == est.t.shape and np.all(est.step_time > 0)
    assert est.diagnostics["final_change"] < 1e-6
    # the online estimates (what a filter would report at each step) are far better than dead reckoning
    truth = _truth_at(seq, est.t)
    online = np.abs(_world_error(est.diagnostics["online_poses"], truth)[:, :2]).mean()
    dead_reckoning = np.abs(_world_error(build_problem(seq).dead_reckoning(), truth)[:, :2]).mean()
    assert online < 0.3 * dead_reckoning


def test_isam2_online_output_is_each_pose_right_after_its_update(seq, batch):
    """output='online': the Estimate's poses are the online estimates (diagnostics), without pose covariances; the
    landmarks are still the final ones."""
    smoothed = ISAM2Smoother().run(seq)
    online = ISAM2Smoother(output="online").run(seq)
    np.testing.assert_array_equal(online.poses, smoothed.diagnostics["online_poses"])
    assert online.pose_cov is None and online.landmark_cov is not None
    np.testing.assert_array_equal(online.landmarks, smoothed.landmarks)
    assert np.abs(_world_error(online.poses, batch.poses)).max() > 1e-3  # not the smoothed answer


def test_isam2_without_final_updates_differs_from_batch(seq, batch):
    """The final updates are what make iSAM2 equal batch (with GTSAM's default thresholds)."""
    est = ISAM2Smoother(final_updates=0, covariances=False).run(seq)
    assert np.abs(_world_error(est.poses, batch.poses)).max() > 1e-5


@pytest.mark.parametrize("optimizer", ["gauss_newton", "dogleg"])
def test_optimizers_reach_the_same_optimum(seq, batch, optimizer):
    est = BatchSmoother(optimizer=optimizer, covariances=False).run(seq)
    assert np.abs(_world_error(est.poses, batch.poses)).max() < 1e-6
    assert est.diagnostics["final_error"] == pytest.approx(batch.diagnostics["final_error"], rel=1e-9)


def test_increments_input_gives_the_same_answer_as_twist(seq, batch):
    """The same motion as odometry increments with covariance V M Vᵀ per row (arc model)."""
    tw = seq.motion
    M = seq.noise.twist_cov
    delta = ARC.increment(tw.v, tw.omega, tw.dt)
    _, V = ARC.jacobians(np.zeros((len(tw), 3)), tw.v, tw.omega, tw.dt)
    inc = Increments(t=np.append(tw.t[1:], tw.t[-1] + tw.dt[-1]), delta=delta, cov=V @ M @ np.swapaxes(V, 1, 2))
    inc_seq = dataclasses.replace(seq, motion=inc)
    est = BatchSmoother(covariances=False).run(inc_seq)
    np.testing.assert_allclose(est.t[1:], batch.t[1:], atol=1e-9)
    assert np.abs(_world_error(est.poses[1:], batch.poses[1:])).max() < 1e-6


def _with_outliers(seq, fraction, rng):
    rb = seq.range_bearing
    bad = rng.random(len(rb)) < fraction
    rng_ = rb.range + np.where(bad, rng.uniform(3.0, 6.0, len(rb)), 0.0)
    return dataclasses.replace(
        seq, range_bearing=RangeBearing(t=rb.t, range=rng_, bearing=rb.bearing, landmark_id=rb.landmark_id)
    ), bad


@pytest.mark.parametrize("kernel", ["huber", "cauchy"])
def test_robust_kernels_resist_outliers(seq, kernel):
    bad_seq, _ = _with_outliers(seq, 0.05, np.random.default_rng(7))
    truth = _truth_at(seq, BatchSmoother(covariances=False).run(seq).t)
    plain = BatchSmoother(covariances=False).run(bad_seq)
    robust = BatchSmoother(covariances=False, robust=kernel).run(bad_seq)
    err = lambda e: np.sqrt(np.mean(np.sum(_world_error(e.poses, truth)[:, :2] ** 2, axis=1)))  # noqa: E731
    assert err(robust) < 0.5 * err(plain)


def _with_ranges(seq, rows, values):
    rb = seq.range_bearing
    r = rb.range.copy()
    r[rows] = values
    return dataclasses.replace(
        seq, range_bearing=RangeBearing(t=rb.t, range=r, bearing=rb.bearing, landmark_id=rb.landmark_id)
    )


def test_nonfinite_absurd_negative_and_unknown_observations_are_rejected_and_counted(seq, batch):
    """A range of 1e300 m is finite but its square is not (it made the error inf and the dead-reckoned guess came back
    as the result); a negative range is no range (EKF-SLAM rejects it too). Counted, and never in the graph."""
    bad = _with_ranges(seq, [5, 40, 41, 60], [np.nan, np.inf, 1e300, -2.0])
    ids = bad.range_bearing.landmark_id.copy()
    ids[[7, 8, 9]] = -1
    bad = dataclasses.replace(bad, range_bearing=dataclasses.replace(bad.range_bearing, landmark_id=ids))
    est = BatchSmoother(covariances=False).run(bad)
    assert est.diagnostics["rejected_nonfinite_observations"] == 3
    assert est.diagnostics["rejected_negative_range_observations"] == 1
    assert est.diagnostics["skipped_unknown_id_observations"] == 3
    assert (
        np.isfinite(est.diagnostics["final_error"])
        and est.diagnostics["final_error"] < est.diagnostics["initial_error"]
    )
    assert np.all(np.isfinite(est.poses)) and np.abs(_world_error(est.poses, batch.poses)).max() < 0.05


def test_odometry_rows_with_bad_values_or_covariances_are_rejected_and_counted(seq):
    """Increments whose value is not summable or whose own covariance is non-finite or not positive semidefinite are
    dropped and counted (a NaN covariance made GTSAM's error NaN)."""
    tw = seq.motion
    delta = ARC.increment(tw.v, tw.omega, tw.dt)
    _, V = ARC.jacobians(np.zeros((len(tw), 3)), tw.v, tw.omega, tw.dt)
    cov = V @ seq.noise.twist_cov @ np.swapaxes(V, 1, 2)
    delta[12] = 1e300
    cov[5] = np.nan
    cov[9] = -cov[9]
    inc = Increments(t=np.append(tw.t[1:], tw.t[-1] + tw.dt[-1]), delta=delta, cov=cov)
    est = BatchSmoother(covariances=False).run(dataclasses.replace(seq, motion=inc))
    assert est.diagnostics["rejected_nonfinite_motion"] == 1 and est.diagnostics["rejected_invalid_cov_motion"] == 2
    truth = _truth_at(seq, est.t[1:])  # the start pose is one period before the first increment's stamp
    assert np.sqrt(np.mean(np.sum(_world_error(est.poses[1:], truth)[:, :2] ** 2, axis=1))) < 0.15


def test_a_singular_motion_covariance_is_rejected_before_the_graph(seq):
    """The Euler model has no lateral noise: without regularisation a between factor's covariance is singular (GTSAM's
    error would be NaN, its Marginals 'indeterminate')."""
    with pytest.raises(ValueError, match="singular covariance.*regularisation"):
        BatchSmoother(regularisation=0.0, motion_model="euler").run(seq)


@pytest.mark.parametrize(
    "row,stop,update", [(40, "gave up, no damping", 99), (8, "not converged within max_iterations = 100", 19)]
)
def test_a_gross_outlier_without_a_kernel_is_an_error_and_a_huber_kernel_absorbs_it(seq, row, stop, update):
    """One range ×100: finite and positive, so no input check rejects it. Plain least squares (robust='none', the
    default) stopped at ½χ² ≈ 10⁷ and returned that as the result; now, from dead reckoning, Levenberg-Marquardt giving up
    (row 40) or running out of iterations (row 8, a first sighting: the landmark starts 100× too far) is an
    OptimizationError. A Huber kernel 3σ wide down-weights the outlier and gives the clean answer (research/method/graph_slam_robust.md,
    robust kernels). From iSAM2's estimate (the default start) the error is iSAM2's: undamped, it diverges on the outlier."""
    bad = _with_ranges(seq, [row], [100 * seq.range_bearing.range[row]])
    from_dead_reckoning = dict(covariances=False, initial="dead_reckoning")
    with pytest.raises(OptimizationError, match=f"Levenberg-Marquardt, .*: {stop}.*still promises a decrease of"):
        BatchSmoother(**from_dead_reckoning).run(bad)
    with pytest.raises(
        OptimizationError, match=rf"start \(initial='isam2'\): iSAM2 update {update} .*initial='dead_reckoning'"
    ):
        BatchSmoother(covariances=False).run(bad)
    huber = dict(from_dead_reckoning, robust="huber", robust_k=3.0)
    clean = BatchSmoother(**huber).run(seq)
    assert np.abs(_world_error(BatchSmoother(**huber).run(bad).poses, clean.poses)[:, :2]).max() < 0.05


def test_a_diverging_isam2_is_an_error_before_the_stiffness_rule_uses_its_marginal(seq):
    """iSAM2 with QR on a range ×100 at a first sighting diverges (½χ² 10³⁶); the marginal covariance the stiffness rule
    reads is then not positive definite, which made numpy's eigendecomposition fail ('did not converge')."""
    bad = _with_ranges(seq, [8], [100 * seq.range_bearing.range[8]])
    with pytest.raises(
        OptimizationError, match=r"iSAM2 update \d+ .*: the marginal covariance of x\d+ is not positive definite"
    ):
        ISAM2Smoother(factorization="QR", covariances=False).run(bad)


def test_a_diverging_optimisation_is_an_error(seq):
    """Gauss-Newton on a stiff graph (regularisation 1e-6, research/method/graph_slam.md) from dead reckoning multiplies the
    error by 50 in its first step and stops there (GTSAM: 'error increased'); that was returned as the result."""
    with pytest.raises(OptimizationError, match="Gauss-Newton, 1 iterations, .*: diverging"):
        BatchSmoother(optimizer="gauss_newton", regularisation=1e-6, initial="dead_reckoning", covariances=False).run(
            seq
        )


def test_a_nonfinite_error_is_an_error_naming_the_factor():
    graph = gtsam.NonlinearFactorGraph()
    graph.add(gtsam.PriorFactorPose2(X(0), gtsam.Pose2(), gtsam.noiseModel.Unit.Create(3)))
    graph.add(gtsam.PriorFactorPoint2(L(3), gtsam.Point2(1e300, 0.0), gtsam.noiseModel.Unit.Create(2)))
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose2())
    values.insert(L(3), gtsam.Point2(0.0, 0.0))
    with pytest.raises(
        OptimizationError, match="at the initial values: the error is inf .*factor 1, PriorFactorPoint2 on l3"
    ):
        optimize(graph, values, OptimizerParams())


def test_isam2_indeterminate_system_is_an_optimization_error_naming_the_update(seq):
    """GTSAM's raw RuntimeError ('Indeterminate linear system') becomes OptimizationError with the update, its time and
    the variable GTSAM names. Trigger: with the stiffness rule off, a between factor whose lateral variance is 1e-12 of
    its largest (the Euler model has no lateral noise); with the rule (the default) the same graph is solved."""
    stiff = dict(regularisation=1e-12, motion_model="euler", covariances=False)
    with pytest.raises(
        OptimizationError, match=r"iSAM2 update 1 \(t = 0\.1 s\): GTSAM: Indeterminate linear system .* variable x1"
    ):
        ISAM2Smoother(uncertainty_floor=None, **stiff).run(seq)
    assert ISAM2Smoother(**stiff).run(seq).diagnostics["lifted_between"] > 0


@pytest.mark.slow  # ≈ 15–30 s on the shared 2-core machine
def test_isam2_finishes_where_cholesky_called_the_newest_pose_indeterminate():
    """sim:landmarks with 200 landmarks, seed 0: at update 754 the pose is 0.4 m = 2¹² σ_min of a 0.1 s step uncertain
    sideways, GTSAM's Cholesky finds x_k's lateral pivot below 2⁻²⁴ of its diagonal and raised 'indeterminate linear
    system near l10' (the clique's first key). The stiffness rule (uncertainty_floor) lifts such between factors to 2⁻²² of
    the pose's uncertainty, and the run finishes (research/method/graph_slam.md)."""
    seq = simulate(seed=0, n_landmarks=200)
    est = ISAM2Smoother(covariances=False).run(seq)
    assert est.diagnostics["lifted_between"] > 0 and est.diagnostics["final_change"] < 1e-6
    truth = _truth_at(seq, est.t)
    dead_reckoning = build_problem(seq).dead_reckoning()
    rmse = lambda p: np.sqrt(np.mean(np.sum(_world_error(p, truth)[:, :2] ** 2, axis=1)))  # noqa: E731
    assert rmse(est.poses) < 0.3 * rmse(dead_reckoning)


def test_batch_given_isam2s_between_covariances_solves_isam2s_graph():
    """iSAM2 lifts 87 of 292 between factors here (a 4 m sensor range leaves the pose uncertain between sightings): its
    optimum differs from the batch optimum of the problem's graph by 6·10⁻⁶, and equals the batch optimum of its own graph
    (diagnostics["between_cov"] given to BatchSmoother.run) — poses, landmarks and covariances."""
    seq = simulate(seed=0, n_landmarks=30, max_range=4.0)
    inc = ISAM2Smoother().run(seq)
    assert inc.diagnostics["lifted_between"] > 50
    own = BatchSmoother().run(seq)
    assert np.abs(_world_error(inc.poses, own.poses)).max() > 1e-6
    same = BatchSmoother().run(seq, between_cov=inc.diagnostics["between_cov"])
    assert np.abs(_world_error(inc.poses, same.poses)).max() < 1e-6
    np.testing.assert_allclose(inc.landmarks, same.landmarks, atol=1e-6)
    assert_covariances_close(inc.pose_cov, same.pose_cov, rtol=1e-3)
    assert_covariances_close(inc.landmark_cov, same.landmark_cov, rtol=1e-3)
    assert same.diagnostics["final_error"] == pytest.approx(inc.diagnostics["final_error"], rel=1e-9)


@pytest.mark.parametrize("between_cov,match", [(np.zeros((3, 3, 3)), "shape"), ("negative", "between_cov\\[4\\]")])
def test_between_covariances_of_the_wrong_shape_or_not_positive_definite_are_rejected(seq, between_cov, match):
    problem = build_problem(seq)
    if isinstance(between_cov, str):
        between_cov = problem.cov.copy()
        between_cov[4] = -between_cov[4]
    with pytest.raises(ValueError, match=match):
        BatchSmoother(covariances=False).run(seq, between_cov=between_cov)


def test_isam2_final_updates_that_run_out_at_the_optimum_of_their_linearisation_are_the_answer(seq, batch):
    """final_tol below round-off (MRCLAM: a heading between 1 ms steps moves by 10⁻⁵ rad from update to update at ½χ²
    constant to 10⁻⁸) ran the updates out and raised; the answer is the optimum all the same when a Gauss-Newton step
    from it promises a negligible decrease (graph.optimize's rule). Updates that stop far from it still raise."""
    est = ISAM2Smoother(final_tol=1e-12, covariances=False).run(seq)
    assert est.diagnostics["final_updates_used"] == 10 and est.diagnostics["final_change"] > 1e-12
    assert np.abs(_world_error(est.poses, batch.poses)).max() < 1e-6
    with pytest.raises(OptimizationError, match="after 1 a variable still moved by .* still promises a decrease of"):
        ISAM2Smoother(relinearize_threshold=100.0, final_updates=1, covariances=False).run(seq)


def test_batch_from_isam2s_estimate_converges_where_dead_reckoning_does_not():
    """100 landmarks, σ_ω = 0.2 rad/s, seed 1: from dead reckoning Levenberg-Marquardt is still descending after 100
    iterations (½χ² 3.2·10⁶ → 8 652.6, an OptimizationError); from iSAM2's estimate (initial="isam2", the default) it
    reaches the optimum 8 624.6 in a few."""
    seq = simulate(seed=1, n_landmarks=100, sigma_omega=0.2)
    est = BatchSmoother(covariances=False).run(seq)
    assert est.diagnostics["iterations"] <= 10
    dof = 2 * len(seq.range_bearing) - 2 * len(est.landmarks)  # the between factors and the prior fit the poses
    assert 0.5 * chi2_band(dof, 1, 0.999)[0] < est.diagnostics["final_error"] < 0.5 * chi2_band(dof, 1, 0.999)[1]
    truth = _truth_at(seq, est.t)
    rmse = lambda p: np.sqrt(np.mean(np.sum(_world_error(p, truth)[:, :2] ** 2, axis=1)))  # noqa: E731
    assert rmse(est.poses) < 0.3 * rmse(build_problem(seq).dead_reckoning())


def test_the_runner_reports_a_failed_optimisation_as_a_failed_cell(tmp_path):
    """A cell whose smoother raises is 'error' with the message, never 'ok' (the diverging Gauss-Newton cell was 'ok')."""
    import os
    import textwrap

    import pandas as pd
    from rich.console import Console

    from slamarena.experiments.config import load_config
    from slamarena.experiments.runner import run_experiment

    path = tmp_path / "exp.yaml"
    path.write_text(
        textwrap.dedent("""
        name: failing
        seeds: 1
        datasets:
          - name: sim:landmarks
            params: {n_landmarks: 30, laps: 1}
        estimators:
          - name: gtsam_batch
            params: {optimizer: gauss_newton, regularisation: 1.0e-6, initial: dead_reckoning, covariances: false}
          - name: gtsam_isam2
            params: {regularisation: 1.0e-12, motion_model: euler, uncertainty_floor: null}
        metrics: [ate]
        figures: []
    """)
    )
    with open(os.devnull, "w") as quiet:
        assert run_experiment(load_config(path), tmp_path / "out", jobs=1, console=Console(file=quiet)) == 1
    summary = pd.read_csv(tmp_path / "out" / "summary.csv").set_index("estimator")
    assert (summary["status"] == "error").all()
    assert "OptimizationError: Gauss-Newton" in summary.at["gtsam_batch", "error"]
    assert (
        "OptimizationError: iSAM2 update 1" in summary.at["gtsam_isam2", "error"]
        and "x1" in summary.at["gtsam_isam2", "error"]
    )


@pytest.mark.parametrize(
    "params",
    [
        dict(robust="tukey"),
        dict(optimizer="newton"),
        dict(prior_sigma=[0.1, 0.1]),
        dict(max_interval=-1.0),
        dict(regularisation=2.0),
    ],
)
def test_bad_config_is_rejected_before_work(params):
    with pytest.raises(ValueError, match=next(iter(params))):
        BatchSmoother(**params)


@pytest.mark.parametrize(
    "cls,bad,given,cov",
    [
        (
            BatchSmoother,
            dict(max_iterations=0),
            dict(optimizer="dogleg", twist_cov=0.01, prior_sigma=[0.1, 0.1, 0.05]),
            "twist_cov",
        ),
        (
            ISAM2Smoother,
            dict(factorization="LU"),
            dict(relinearize_skip=1, range_bearing_cov=[0.01, 1e-4], step_clock="cpu"),
            "range_bearing_cov",
        ),
    ],
)
def test_parameters_are_one_model(cls, bad, given, cov):
    with pytest.raises(ValidationError, match=next(iter(bad))):
        cls(**bad)
    with pytest.raises(ValidationError, match="relinearise_skip"):
        cls(relinearise_skip=1)  # a misspelt parameter is an error, never ignored
    assert cls(cls.Params(**given)).params == cls(**given).params
    made = cls(**given)
    # a covariance given as a scalar or a diagonal is stored as the full matrix; the canonical form rebuilds the same model
    assert np.asarray(getattr(made.params, cov)).shape == (2, 2)
    assert cls(made.params.canonical()).params == made.params
    # the landmark problem's fields are the landmark smoothers' (one model), with the same defaults
    assert set(LandmarkProblemParams.model_fields) < set(cls.Params.model_fields)
    assert {k: getattr(cls().params, k) for k in LandmarkProblemParams.model_fields} == dict(LandmarkProblemParams())


def test_missing_noise_is_a_clear_error(seq):
    from slamarena.datasets.sequence import Noise

    with pytest.raises(ValueError, match="twist_cov"):
        BatchSmoother().run(dataclasses.replace(seq, noise=Noise(range_bearing_cov=seq.noise.range_bearing_cov)))


def test_max_interval_adds_pose_keys(seq):
    coarse = dataclasses.replace(
        seq, range_bearing=seq.range_bearing.select(np.isin(seq.range_bearing.t, seq.range_bearing.t[::200]))
    )
    few = build_problem(coarse)
    many = build_problem(coarse, LandmarkProblemParams(max_interval=1.0))
    assert many.n_poses > few.n_poses + 30
    # the chain of relative motions composes to the same end pose either way
    np.testing.assert_allclose(few.dead_reckoning()[-1], many.dead_reckoning()[-1], atol=1e-9)
    np.testing.assert_allclose(compose(few.start, np.zeros(3)), many.start)
