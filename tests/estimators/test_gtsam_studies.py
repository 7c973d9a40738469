"""The GTSAM smoothers on the staged real data: what research/notebook/2026-11-23-graph-slam-results.md finds, as
assertions (slow; not in the default suite). The tables of these runs are printed by
``research/scripts/gtsam_studies.py``; the pose graphs are the shipped config ``pose_graphs``.
"""

from __future__ import annotations

import numpy as np
import pytest

gtsam = pytest.importorskip("gtsam")

from slamarena import datasets  # noqa: E402
from slamarena.datasets.geometry import wrap_angle  # noqa: E402
from slamarena.estimators.gtsam_smoother import BatchSmoother, ISAM2Smoother, OptimizationError  # noqa: E402
from slamarena.experiments.config import load_config  # noqa: E402
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error  # noqa: E402
from slamarena.experiments.metrics.reference import reference_of  # noqa: E402
from slamarena.experiments.metrics.trajectory import ATEParams, ate  # noqa: E402

pytestmark = pytest.mark.slow


def mrclam_noise() -> dict:
    """MRCLAM's sensor model as the shipped config ``mrclam`` states it, once, for every method."""
    config = load_config("mrclam")
    ekf = config.estimators[config.estimator_labels().index("ekf_slam")]
    return {key: ekf.params[key] for key in ("twist_cov", "range_bearing_cov")}


def _available(name: str) -> bool:
    info = {d.name: d for d in datasets.available()}
    return name in info and info[name].present


def test_pose_graph_study(tmp_path):
    """The shipped config ``pose_graphs`` (research/results.md, "Pose graphs") on its graphs with true poses: every
    optimisation lowers the error, and the optimum of the iSAM worlds is near their truth."""
    from slamarena.experiments.runner import run_experiment

    config = load_config("pose_graphs")
    present = [label for label, spec in zip(config.dataset_labels(), config.datasets) if _available(spec.name)]
    truth = [label for label in ("manhattanOlson3500", "isam_city10000", "cityTrees10000") if label in present]
    if not truth:
        pytest.skip("no iSAM graph with true poses is staged")
    assert run_experiment(config.reduced(datasets=truth), tmp_path) == 0
    import pandas as pd

    rows = pd.read_csv(tmp_path / "summary.csv").set_index("dataset")
    assert (rows["estimate.final_error"] <= rows["estimate.initial_error"]).all()
    # ATE RMSE measured 2026-11-28 (this test, the reduced config): manhattanOlson3500 0.795 m, isam_city10000 0.0406 m,
    # cityTrees10000 0.103 m. Bounds: 2.5× the measured value, but never looser than the former common bound of 1 m.
    bound = {"manhattanOlson3500": 1.0, "isam_city10000": 0.1, "cityTrees10000": 0.25}
    for label in truth:
        assert rows.at[label, "ate.rmse"] < bound[label], (label, rows.at[label, "ate.rmse"])


def _max_difference(a, b) -> tuple[float, float]:
    """Largest differences of two estimates of the same graph: of any pose or landmark coordinate [m], of any heading [rad]."""
    positions = max(np.abs(a.poses[:, :2] - b.poses[:, :2]).max(), np.abs(a.landmarks - b.landmarks).max())
    return float(positions), float(np.abs(wrap_angle(a.poses[:, 2] - b.poses[:, 2])).max())


def test_mrclam_dataset6_study():
    """Every robot of Dataset 6 (known ids, the noise of experiments/configs/mrclam.yaml, Huber): iSAM2 finishes and
    equals the batch optimum of its graph; the batch smoother (from iSAM2's estimate) beats dead reckoning; from dead
    reckoning it stops in local minima (robots 3 and 5), never lower. Measured 2026-11-28 (robots 1–5): SE(2)-aligned
    ATE 0.115/0.127/0.131/0.202/0.169 m (bound 0.3 m: 1.5× the worst, kept), aligned landmark RMSE
    0.073/0.107/0.126/0.094/0.121 m (bound 0.3 m: 2.4× the worst; was 1.0 m)."""
    from slamarena.estimators.dead_reckoning import DeadReckoning

    common = dict(max_interval=1.0, robust="huber", **mrclam_noise())
    for robot in range(1, 6):
        name = f"utias:6/robot{robot}"
        if not _available(name):
            pytest.skip(f"{name} not staged")
        seq = datasets.load(name)
        ref = reference_of(seq)
        inc = ISAM2Smoother(**common).run(seq)
        est = BatchSmoother(max_iterations=500, **common).run(seq)
        same = BatchSmoother(max_iterations=500, **common).run(seq, between_cov=inc.diagnostics["between_cov"])
        from_dr = BatchSmoother(max_iterations=500, initial="dead_reckoning", covariances=False, **common).run(seq)
        dr = ate(DeadReckoning().run(seq), ref, ATEParams(align="none"))[0]["rmse"]
        assert ate(est, ref, ATEParams(align="none"))[0]["rmse"] < dr, robot
        assert max(_max_difference(inc, same)) < 1e-3, robot
        assert same.diagnostics["final_error"] == pytest.approx(inc.diagnostics["final_error"], abs=1e-2), robot
        assert est.diagnostics["final_error"] <= from_dr.diagnostics["final_error"] + 1e-2, robot
        assert ate(est, ref)[0]["rmse"] < 0.3, robot
        assert landmark_error(est, ref, MapParams(align="se2"))[0]["rmse"] < 0.3, robot


def test_victoria_park_study():
    """One pose per odometry increment, as in the published graph. From iSAM2's estimate (the default start) the batch
    smoother reaches iSAM2's optimum; from dead reckoning Levenberg-Marquardt gives up (an OptimizationError) and Dogleg
    converges to a local minimum."""
    if not _available("victoria_park"):
        pytest.skip("victoria_park not staged")
    seq = datasets.load("victoria_park")
    common = dict(covariances=False, max_interval=1.0, max_iterations=300)
    with pytest.raises(OptimizationError, match="gave up"):
        BatchSmoother(**common, initial="dead_reckoning").run(seq)
    inc = ISAM2Smoother(covariances=False, max_interval=1.0).run(seq)
    default = BatchSmoother(**common).run(seq)
    dogleg = BatchSmoother(**common, initial="dead_reckoning", optimizer="dogleg").run(seq)
    same = BatchSmoother(**common).run(seq, between_cov=inc.diagnostics["between_cov"])
    assert max(_max_difference(inc, same)) < 1e-3 and max(_max_difference(inc, default)) < 1e-2
    assert inc.diagnostics["final_error"] < dogleg.diagnostics["final_error"]
