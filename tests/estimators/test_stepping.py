"""The filters' one event loop (estimators.stepping.blocks): blocks, motion pieces, bad rows skipped and counted, and
the filters' runners bound by their packages (no filter.py ↔ run.py import cycle)."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.sequence import Increments, RangeBearing, Sequence, Twist
from slamarena.estimators import stepping
from slamarena.estimators.stepping import LIMITS, blocks, observation_rows

ROOT = Path(__file__).resolve().parents[2]


def _sequence(motion) -> Sequence:
    """Motion plus observation sets at 1.0 (two rows) and 2.5 s."""
    rb = RangeBearing(
        t=np.array([1.0, 1.0, 2.5]),
        range=np.array([1.0, 2.0, 3.0]),
        bearing=np.zeros(3),
        landmark_id=np.array([0, 1, 0]),
    )
    return Sequence(name="walk", motion=motion, range_bearing=rb)


def test_blocks_cut_the_events_at_the_observation_sets_twist():
    v = np.array([1.0, np.nan, 3.0, 4.0])
    seq = _sequence(Twist(t=np.array([0.0, 0.5, 1.0, 2.0]), v=v, omega=np.zeros(4), dt=np.array([0.5, 0.5, 1.0, 1.0])))
    walk = blocks(seq)
    assert [(len(b.chain), b.observation.t if b.observation else None, b.t0, b.t1) for b in walk] == [
        (3, 1.0, 0.0, 1.0),  # rows at 0, 0.5, 1.0 (motion first at equal stamps), then the set at 1.0
        (1, 2.5, 1.0, 2.5),
    ]
    first, second = walk[0].motion, walk[1].motion
    # pieces over (0, 1]: row 0 on [0, 0.5); row 1 is not finite (skipped, counted); row 2 starts at 1.0: no piece
    assert first.kind == "twist" and first.rows.tolist() == [0] and first.rejected == 1
    assert first.v.tolist() == [1.0] and first.dt.tolist() == [0.5]
    assert first.start.tolist() == [0.0] and first.end.tolist() == [0.5]
    assert first.at_event.tolist() == [0, 1, 1]  # a twist row moves the robot from its stamp on
    # over (1, 2.5]: row 2 on [1, 2), row 3 on [2, 2.5]
    assert second.rows.tolist() == [2, 3] and second.dt.tolist() == [1.0, 0.5] and second.end.tolist() == [2.0, 2.5]
    assert second.at_event.tolist() == [1]


def test_blocks_cut_the_events_at_the_observation_sets_increments():
    delta = np.array([[0.1, 0.0, 0.0], [1e300, 0.0, 0.0], [0.3, 0.0, 0.0], [0.4, 0.0, 0.0]])
    seq = _sequence(Increments(t=np.array([0.5, 1.0, 2.0, 3.0]), delta=delta, cov=np.tile(np.eye(3), (4, 1, 1))))
    walk = blocks(seq)
    assert [(len(b.chain), b.observation.t if b.observation else None) for b in walk] == [(2, 1.0), (1, 2.5), (1, None)]
    first = walk[0].motion
    assert first.kind == "increments" and first.rows.tolist() == [0] and first.rejected == 1  # 1e300 m: beyond LIMITS
    assert first.start.tolist() == [-np.inf] and first.end.tolist() == [0.5]
    assert first.at_event.tolist() == [1, 1]  # an increment has moved the robot by its stamp
    assert walk[1].motion.start.tolist() == [1.0] and walk[1].motion.cov.shape == (1, 3, 3)
    assert blocks(seq, row_cov=False)[1].motion.cov is None  # the filter's own covariance
    assert (walk[2].t0, walk[2].t1) == (2.5, 3.0)  # the motion after the last set, to its last stamp


def test_an_increment_with_a_non_finite_covariance_is_skipped_only_when_its_covariance_is_used():
    cov = np.tile(np.eye(3), (2, 1, 1))
    cov[0, 0, 0] = np.nan
    seq = _sequence(Increments(t=np.array([0.5, 1.0]), delta=np.full((2, 3), 0.1), cov=cov))
    assert blocks(seq)[0].motion.rows.tolist() == [1] and blocks(seq)[0].motion.rejected == 1
    assert blocks(seq, row_cov=False)[0].motion.rows.tolist() == [0, 1]  # the filter's own covariance is used


def test_observation_rows_leave_out_ranges_beyond_the_physical_range_only():
    ranges = np.array([1.0, np.nan, -1.0, LIMITS.range, 2 * LIMITS.range, 5.0])
    rows, far = observation_rows(datasets.sequence.Event(0.0, "range_bearing", 0, 6), ranges)
    assert rows.tolist() == [0, 1, 2, 3, 5] and far == 1  # NaN and negative rows are the filter's to count


@pytest.fixture(scope="module")
def sim():
    return datasets.load("sim:landmarks", n_landmarks=10, laps=1, seed=0)


def _with(seq: Sequence, stream: str, **columns) -> Sequence:
    return dataclasses.replace(seq, **{stream: dataclasses.replace(getattr(seq, stream), **columns)})


@pytest.mark.parametrize(
    "method, params",
    [("ekf_slam", {"use_ids": False}), ("ekf_slam", {}), ("fastslam", {"particles": 20}), ("fastslam", {"version": 1})],
)
def test_a_range_beyond_the_physical_range_is_skipped_and_counted(sim, method, params):
    """EKF-SLAM without ids aborted on this row (a 1e20 m landmark whose covariance cancels to an indefinite S:
    CovarianceError); FastSLAM made its weights NaN. Now the row is left out: the run equals the run without it."""
    from slamarena.estimators import create

    row = 5
    ranges = sim.range_bearing.range.copy()
    ranges[row] = 1e20
    bad = create(method, **params).run(_with(sim, "range_bearing", range=ranges))
    keep = np.arange(len(sim.range_bearing)) != row
    clean = create(method, **params).run(dataclasses.replace(sim, range_bearing=sim.range_bearing.select(keep)))
    assert int(bad.diagnostics["rejected_out_of_range"]) == 1 and int(clean.diagnostics["rejected_out_of_range"]) == 0
    np.testing.assert_array_equal(bad.t, clean.t)
    np.testing.assert_array_equal(bad.poses, clean.poses)
    np.testing.assert_array_equal(bad.landmarks, clean.landmarks)


@pytest.mark.parametrize("method", ["ekf_slam", "fastslam"])
@pytest.mark.parametrize("value", [1e300, 1e20])
def test_a_motion_row_beyond_the_physical_range_is_skipped_as_a_non_finite_row_is(sim, method, value):
    """EKF-SLAM aborted on both (ValueError at 1e300 m/s, CovarianceError later at 1e20); FastSLAM raised or gave NaN
    poses. Now the row is skipped and counted exactly like a non-finite one."""
    from slamarena.estimators import create

    v_bad, v_nan = sim.motion.v.copy(), sim.motion.v.copy()
    v_bad[10], v_nan[10] = value, np.nan
    bad = create(method).run(_with(sim, "motion", v=v_bad))
    nan = create(method).run(_with(sim, "motion", v=v_nan))
    assert int(bad.diagnostics["rejected_motion"]) == int(nan.diagnostics["rejected_motion"]) == 1
    assert np.isfinite(bad.poses).all()
    np.testing.assert_array_equal(bad.poses, nan.poses)


@pytest.mark.parametrize("package", ["ekf_slam", "fastslam", "ekf_localizer"])
def test_a_filter_does_not_import_its_runner_and_the_package_binds_run(package):
    import importlib

    tree = ast.parse((ROOT / "estimators" / package / "filter.py").read_text())
    imported = [
        f"{'.' * node.level}{node.module or ''}"
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[-1] == "run"
    ]
    assert not imported, f"estimators/{package}/filter.py imports {imported}"
    module = importlib.import_module(f"slamarena.estimators.{package}")
    cls = getattr(module, {"ekf_slam": "EKFSLAM", "fastslam": "FastSLAM", "ekf_localizer": "EKFLocalizer"}[package])
    runner = importlib.import_module(f"slamarena.estimators.{package}.run")
    assert cls.run is runner.run_sequence


def test_the_limits_are_far_beyond_what_the_simulators_produce(sim):
    assert np.nanmax(sim.range_bearing.range) < LIMITS.range / 100
    assert np.abs(sim.motion.v).max() < LIMITS.speed / 10 and np.abs(sim.motion.omega).max() < LIMITS.turn_rate / 10
    assert stepping.LIMITS is LIMITS
