"""GridSLAM: accuracy on hand-made and simulated drives, bad scans counted, configuration errors."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from conftest import make_sequence
from pydantic import ValidationError

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sequence import Scans, Sequence
from slamarena.mapping.evaluation import occupancy_agreement
from slamarena.mapping.grid_slam import GridSLAM


def rms_xy(est, truth):
    return float(np.sqrt(np.mean(np.sum((est.poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


def aligned_ate(est, seq):
    """Position RMSE after SE(2) alignment (a SLAM map and trajectory are defined up to their frame)."""
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate

    return ate(est, reference_of(seq), ATEParams())[0]["rmse"]


@pytest.mark.parametrize(
    "matcher,params,tol",
    [
        ("gauss_newton", {}, 0.02),
        ("gauss_newton", {"prior_translation_weight": 0.0, "prior_rotation_weight": 0.0}, 0.03),  # pure Hector
        ("branch_and_bound", {"linear_window": 0.2, "angular_window": 0.1}, 0.03),
        ("kiss_icp", {}, 0.03),
    ],
)
def test_room_drive_beats_odometry(room_sequence, matcher, params, tol):
    truth = room_sequence.ground_truth.poses
    est = GridSLAM(frontend={"matcher": matcher, "matcher_params": params}).run(room_sequence)
    odometry = aligned_ate(Estimate("odometry", room_sequence.scans.t, room_sequence.scans.pose), room_sequence)
    assert odometry > 0.05
    assert aligned_ate(est, room_sequence) < tol, matcher
    assert rms_xy(est, truth) < 0.1
    # pure Hector can jump by a few degrees on the second scan (a one-scan map), then recovers
    assert np.abs(np.angle(np.exp(1j * (est.poses[:, 2] - truth[:, 2]))))[2:].max() < 0.03
    assert est.step_time.shape == (len(truth),) and np.all(est.step_time > 0)
    assert est.diagnostics["matched"][1:].all() and est.meta["map_updates"] >= 10


def test_sim_laser_trajectory_and_map_against_the_truth():
    """ATE after SE(2) alignment, and the map against the true walls moved by the same alignment."""
    pytest.importorskip("slamarena.datasets.sim.laser")
    from slamarena.datasets.geometry import inverse
    from slamarena.datasets.sim.laser import simulate
    from slamarena.experiments.metrics.alignment import fit_alignment
    from slamarena.experiments.metrics.reference import associate, reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate
    from slamarena.mapping.evaluation import true_occupancy_on

    seq = simulate(seed=1)
    slam = GridSLAM()
    est = slam.run(seq)
    odometry = Estimate("odometry", seq.scans.t, seq.scans.pose)
    ate_slam, _ = ate(est, reference_of(seq), ATEParams())
    ate_odometry, _ = ate(odometry, reference_of(seq), ATEParams())
    assert ate_slam["rmse"] < 0.02 and ate_odometry["rmse"] > 0.1, (ate_slam, ate_odometry)
    match = associate(reference_of(seq), est.t, 0.1)
    A = fit_alignment(est.poses[match.index, :2], match.gt[:, :2], "se2")
    truth_in_map = inverse(np.array([*A.translation, A.angle]))
    aligned = occupancy_agreement(slam.map, true_occupancy_on(slam.map, "loop", truth_in_map))
    assert aligned["iou"] > 0.55 and aligned["precision"] > 0.95 and aligned["recall"] > 0.95, aligned
    # the map one cell off the truth agrees much less
    off = occupancy_agreement(
        slam.map, true_occupancy_on(slam.map, "loop", truth_in_map + np.array([0.05, 0.0, 0.0])), tol=0
    )
    assert off["iou"] < 0.6 * aligned["iou"], (off, aligned)


def _with_ranges(seq: Sequence, ranges: np.ndarray) -> Sequence:
    return dataclasses.replace(seq, scans=dataclasses.replace(seq.scans, ranges=ranges))


def test_bad_scans_are_handled_and_counted(room_sequence):
    clean = GridSLAM().run(room_sequence)
    r = room_sequence.scans.ranges.copy()
    B = r.shape[1]
    r[5, :3] = [np.nan, np.inf, -np.inf]
    r[6, 10:12] = [0.0, -1.0]
    r[20, :] = room_sequence.scans.max_range  # all no-return
    r[30, :] = np.nan  # all bad
    r[40, :] = 25.0  # beyond max range: no-return too
    est = GridSLAM().run(_with_ranges(room_sequence, r))
    d = est.diagnostics
    assert d["bad_beams"][5] == 3 and d["bad_beams"][6] == 2 and d["bad_beams"][30] == B
    assert d["bad_beams"].sum() == 3 + 2 + B
    assert d["no_return_beams"][20] == B and d["no_return_beams"][40] == B
    assert not d["matched"][[20, 30, 40]].any() and d["matched"][[5, 6, 21]].all()
    assert est.meta["scans_all_bad"] == 1 and est.meta["scans_all_no_return"] == 3  # 20, 30 (bad + none), 40
    assert est.meta["scans_not_matched"] == 4  # the first scan and the three empty ones
    assert np.all(np.isfinite(est.poses)) and np.isnan(d["match_cov"][30]).all()
    assert aligned_ate(est, room_sequence) < 0.03 and aligned_ate(clean, room_sequence) < 0.03


def test_estimate_round_trip_and_map_export(room_sequence, tmp_path):
    slam = GridSLAM(pyramid={"resolution": 0.1, "levels": 2})
    est = slam.run(room_sequence)
    est.save(tmp_path / "e.npz")
    back = Estimate.load(tmp_path / "e.npz")
    assert np.allclose(back.poses, est.poses) and back.meta["params"]["pyramid"]["resolution"] == 0.1
    assert slam.map.params.resolution == 0.1 and len(slam.maps.levels) == 2
    pgm, yml = slam.map.save_map_server(tmp_path / "map")
    assert pgm.exists() and yml.exists()


def test_configuration_errors_before_work():
    with pytest.raises(ValidationError, match="frontend.matcher"):
        GridSLAM(frontend={"matcher": "ndt"})
    with pytest.raises(ValidationError, match="pyramid.resolution"):
        GridSLAM(pyramid={"resolution": 0})
    with pytest.raises(ValidationError, match="frontend.min_beams"):
        GridSLAM(frontend={"min_beams": 1})
    with pytest.raises(
        ValidationError, match=r"matcher_params\.no_such_parameter\s+no_such_parameter: not a parameter"
    ):
        GridSLAM(frontend={"matcher_params": {"no_such_parameter": 1}})
    with pytest.raises(ValueError, match="laser scans"):
        GridSLAM().run(Sequence(name="empty"))


def test_parameters_bad_values_unknown_keys_and_the_model_form():
    with pytest.raises(ValidationError, match="frontend.update_angle"):
        GridSLAM(frontend={"update_angle": -0.1})
    with pytest.raises(ValidationError, match="frontend.max_usable_range"):
        GridSLAM(frontend={"max_usable_range": 0.0})
    with pytest.raises(ValidationError, match="no_such_parameter: not a parameter of GridSLAMParams"):
        GridSLAM(no_such_parameter=1)
    with pytest.raises(ValidationError, match="p_miss < p_prior < p_hit"):  # the cell model's rule
        GridSLAM(pyramid={"cells": {"p_miss": 0.6}})
    with pytest.raises(ValidationError, match=r"clamp \(p_min, p_max\)"):
        GridSLAM(pyramid={"cells": {"clamp": (0.55, 0.97)}})
    with pytest.raises(ValidationError, match=r"matcher_params\.sigma"):  # validated by the chosen matcher's model
        GridSLAM(frontend={"matcher": "correlative", "matcher_params": {"sigma": 0.0}})
    with pytest.raises(
        ValidationError, match=r"matcher_params\.sigma\s+sigma: not a parameter of GaussNewtonMatcherParams"
    ):  # a correlative parameter is not a Gauss-Newton one
        GridSLAM(frontend={"matcher_params": {"sigma": 0.1}})
    assert (
        GridSLAM(GridSLAM.Params(frontend={"update_distance": 1.0, "matcher": "kiss_icp"})).params
        == GridSLAM(frontend={"update_distance": 1.0, "matcher": "kiss_icp"}).params
    )
    slam = GridSLAM(
        frontend={"matcher": "branch_and_bound", "matcher_params": {"linear_window": 0.2}},
        pyramid={"cells": {"p_hit": 0.8}},
    )
    assert slam.params.frontend.update_distance == 0.4 and slam.params.pyramid.cells.p_hit == 0.8
    assert slam.matcher.params.linear_window == 0.2
    # the canonical form holds every matcher parameter, defaults included (cache keys and Estimate.meta)
    assert slam.params.canonical()["frontend"]["matcher_params"] == slam.matcher.params.canonical()
    assert slam.params.canonical()["frontend"]["matcher_params"]["covariance_cells"] == 2


def test_a_flat_name_of_earlier_versions_is_refused_naming_its_new_path():
    for flat, value, path in (
        ("p_hit", 0.8, "pyramid.cells.p_hit"),
        ("matcher", "correlative", "frontend.matcher"),
        ("levels", 2, "pyramid.levels"),
    ):
        with pytest.raises(
            ValidationError, match=re.escape(f"{flat}: not a parameter of GridSLAMParams; did you mean {path}?")
        ):
            GridSLAM(**{flat: value})


def test_experiment_config_rejects_a_wrong_matcher_parameter_before_any_cell(tmp_path):
    from slamarena.experiments.config import ConfigError, load_config

    config = """
name: tiny
seeds: [0]
datasets:
  - name: sim:laser
estimators:
  - name: grid_slam
    params: {frontend: {matcher: correlative, matcher_params: PARAMS}}
metrics: [ate]
"""
    path = tmp_path / "exp.yaml"
    path.write_text(config.replace("PARAMS", "{linear_window: 0.2}"))
    (method,) = load_config(path).estimators
    assert (
        method.resolved_params()["frontend"]["matcher_params"]
        == GridSLAM(frontend={"matcher": "correlative", "matcher_params": {"linear_window": 0.2}}).params.canonical()[
            "frontend"
        ]["matcher_params"]
    )
    for bad, message in (
        (
            "{linear_window: -1}",
            "params.frontend.matcher_params.linear_window: Input should be greater than or equal to 0",
        ),
        (
            "{iterations: 3}",
            "params.frontend.matcher_params.iterations: not a parameter of CorrelativeMatcherParams",
        ),
    ):
        path.write_text(config.replace("PARAMS", bad))
        with pytest.raises(ConfigError, match=re.escape(message)):
            load_config(path)


def test_without_odometry_and_with_a_mounted_sensor():
    seq = make_sequence(n=60, seed=3)
    mount = np.array([0.25, 0.05, 0.1])
    # re-simulate the scans from the mounted sensor
    from conftest import raycast

    from slamarena.datasets.geometry import compose

    truth = seq.ground_truth.poses
    ranges = np.stack([raycast(compose(p, mount), seq.scans.angles) for p in truth])
    scans = Scans(
        t=seq.scans.t,
        ranges=ranges,
        angles=seq.scans.angles,
        max_range=seq.scans.max_range,
        mount=mount,
        pose=seq.scans.pose,
    )
    mounted = dataclasses.replace(seq, scans=scans)
    assert aligned_ate(GridSLAM().run(mounted), seq) < 0.03
    assert aligned_ate(GridSLAM(frontend={"use_odometry": False}).run(seq), seq) < 0.03
    ignoring_mount = Scans(t=scans.t, ranges=ranges, angles=scans.angles, max_range=scans.max_range, pose=scans.pose)
    assert aligned_ate(GridSLAM().run(dataclasses.replace(seq, scans=ignoring_mount)), seq) > 0.05


def test_frozen_odometry_that_then_jumps_is_not_counted_twice(room_sequence):
    """mit-csail's odometry freezes for a few scans while the robot moves, then jumps by the whole motion:
    the matcher has followed the motion meanwhile, so the jump is applied from the last fresh reading."""
    sc = room_sequence.scans
    odom = sc.pose.copy()
    for start in (40, 80):
        odom[start : start + 6] = odom[start - 1]  # six scans without a new reading, then the true reading again
    frozen = dataclasses.replace(room_sequence, scans=dataclasses.replace(sc, pose=odom))
    est = GridSLAM().run(frozen)
    truth = room_sequence.ground_truth.poses
    assert np.hypot(*(est.poses[:, :2] - truth[:, :2]).T).max() < 0.1  # counted twice: 0.86 m off
    assert est.diagnostics["odometry_stalled"].sum() == 12 and est.meta["odometry_stalled_scans"] == 12
