"""Bad input to the landmark-SLAM filters (EKF-SLAM and FastSLAM, the same tests): rejected, counted, the state unchanged.

The strongest form of "unchanged" is a twin: a filter given the bad input and one never given it (or given the set
without the bad rows) must go on identically, random draws included.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.sequence import RangeBearing, Sequence
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.inputs import CovarianceError


@dataclass(frozen=True)
class Subject:
    """One filter class under test: how to make it, everything its future depends on, and its landmark ids."""

    cls: type
    state: Callable[[object], tuple]
    ids: Callable[[object], np.ndarray]


def _fastslam_state(f: FastSLAM) -> tuple:
    maps = [f.landmarks(m) for m in range(f.M)]
    return (f.x0, f.delta, f.Sigma_delta, f.log_w, f.n_slots, f.n_live, maps, f.rng.bit_generator.state)


EKF = Subject(EKFSLAM, lambda f: (f.x.copy(), f.P.copy(), f.landmark_ids), lambda f: f.landmark_ids)
FAST = Subject(
    FastSLAM,
    lambda f: tuple(np.copy(a) if isinstance(a, np.ndarray) else a for a in _fastslam_state(f)),
    lambda f: f.landmarks()[0],
)
FAST_KW = dict(particles=10, seed=4)

#: (subject, its parameters): EKF-SLAM with each linearisation and update form, FastSLAM 1.0 and 2.0
CASES = [
    pytest.param(EKF, dict(jacobians="standard"), id="ekf-standard"),
    pytest.param(EKF, dict(jacobians="fej"), id="ekf-fej"),
    pytest.param(EKF, dict(jacobians="oc", update="batch"), id="ekf-oc-batch"),
    pytest.param(FAST, dict(version=1, **FAST_KW), id="fastslam1"),
    pytest.param(FAST, dict(version=2, **FAST_KW), id="fastslam2"),
]


def _mapped(subject: Subject, **kw):
    """A filter that has mapped landmarks 0 and 1 (at t = 1 s) and moved since."""
    f = subject.cls(initial_cov=[0.01, 0.01, 0.001], **kw)
    f.update(np.array([[5.0, 0.3, 0], [4.0, -0.5, 1]]), 1.0)
    f.predict((1.0, 0.1), 0.5)
    return f


def _assert_same(subject: Subject, a, b) -> None:
    np.testing.assert_equal(subject.state(a), subject.state(b))


@pytest.mark.parametrize("subject, kw", CASES)
def test_a_failing_prediction_leaves_the_state_as_it_was(subject, kw):
    """Controls whose prediction is not finite, or whose covariance is indefinite, raise before anything changes; the
    filter then goes on as if never called."""
    f, twin = _mapped(subject, **kw), _mapped(subject, **kw)
    cov = 1e-4 * np.eye(3)
    bad = [
        lambda: f.predict((1e300, 0.1), 0.1),  # δ finite, its covariance overflows
        lambda: f.predict((1.0, 0.0), 1e300),
        lambda: f.predict_twists([1.0, 1e200, 1.0], [0.0, 0.0, 0.0], [0.1, 0.1, 0.1]),  # the second of three pieces
        lambda: f.predict((np.nan, 0.0), 0.1),
        lambda: f.predict((1.0, 0.0), 0.0),
        lambda: f.predict((1.0, 0.0), np.nan),
        lambda: f.predict_increments([[1e300, 0.0, 0.0]], [cov]),
        lambda: f.predict_increments([[0.1, 0.0, np.inf]], [cov]),
        lambda: f.predict_increments([[0.1, 0.0, 0.0]], [np.diag([1e-4, np.nan, 1e-4])]),
    ]
    for call in bad:
        with pytest.raises(ValueError):
            call()
        _assert_same(subject, f, twin)
    with pytest.raises(CovarianceError):  # an increment covariance −I
        f.predict_increments([[0.1, 0.0, 0.0]], [-np.eye(3)])
    _assert_same(subject, f, twin)
    for g in (f, twin):
        g.predict((1.0, 0.2), 0.1)
        g.update(np.array([[4.6, 0.2, 0], [3.5, -0.6, 1]]), 2.0)
    _assert_same(subject, f, twin)


@pytest.mark.parametrize("use_ids", [True, False])
@pytest.mark.parametrize("subject, kw", CASES)
def test_absurd_measurements_are_rejected_counted_and_change_nothing(subject, kw, use_ids):
    """Even without a gate: a range the filter cannot represent (the d² or the new landmark's covariance overflows) is
    rejected and counted, and the update is the update of the set without it."""
    f, twin = _mapped(subject, use_ids=use_ids, **kw), _mapped(subject, use_ids=use_ids, **kw)
    rows = ([1e300, 0.2, 0], [1e200, 0.2, 7], [1e160, -0.4, 1])  # mapped landmarks and a new id
    for t, z in enumerate(rows, start=2):
        f.update(np.array([z]), float(t))
        twin.update(np.zeros((0, 3)), float(t))
        _assert_same(subject, f, twin)
    assert f.rejected["nonfinite"] == 3
    # the good row of a set is applied, also after an absurd row of the same landmark
    f.update(np.array([[1e300, 0.2, 0], [4.6, 0.2, 0], [1e300, 0.2, 1]]), 9.0)
    twin.update(np.array([[4.6, 0.2, 0]]), 9.0)
    assert f.rejected["nonfinite"] == 5
    _assert_same(subject, f, twin)
    assert not np.array_equal(subject.state(f)[0], subject.state(_mapped(subject, use_ids=use_ids, **kw))[0])


@pytest.mark.parametrize("subject, kw", CASES)
def test_bad_measurements_are_rejected_and_counted(subject, kw):
    f = subject.cls(**kw)
    z = np.array([[5.0, 0.1, 0], [np.nan, 0.2, 1], [np.inf, 0.0, 2], [-1.0, 0.3, 3], [4.0, np.nan, 4], [3.0, 0.5, 5]])
    f.update(z)
    assert (f.rejected["nonfinite"], f.rejected["negative_range"]) == (3, 1)
    assert sum(f.rejected.values()) == 4
    np.testing.assert_array_equal(subject.ids(f), [0, 5])
    with pytest.raises(ValueError):
        f.update(np.zeros((3, 2)))


@pytest.mark.parametrize("subject, kw", CASES)
def test_a_bad_stamp_raises_and_changes_nothing(subject, kw):
    """An update's stamp must be finite and not before the last update's (the same stamp again is allowed)."""
    f, twin = _mapped(subject, **kw), _mapped(subject, **kw)
    z = np.array([[4.6, 0.2, 0]])
    for t in (np.nan, np.inf, 0.5):  # the last update was at t = 1 s
        with pytest.raises(ValueError, match="stamp"):
            f.update(z, t)
        _assert_same(subject, f, twin)
    for g in (f, twin):
        g.update(z, 1.0)
    _assert_same(subject, f, twin)


@pytest.mark.parametrize("subject, kw", CASES)
def test_a_run_counts_bad_rows_of_a_sequence_and_stays_finite(subject, kw):
    """NaN and absurd (1e300 m) ranges among the simulator's rows: counted, and every pose and covariance is finite."""
    seq = datasets.load("sim:landmarks", n_landmarks=20, seed=5)
    rb = seq.range_bearing
    r = rb.range.copy()
    r[::17] = np.nan
    r[5::23] = 1e300
    bad = Sequence(
        name="bad",
        motion=seq.motion,
        range_bearing=RangeBearing(rb.t, r, rb.bearing, rb.landmark_id),
        ground_truth=seq.ground_truth,
        initial_pose=seq.start_pose,
        noise=seq.noise,
    )
    est = subject.cls(**kw).run(bad)
    assert int(est.diagnostics["rejected_nonfinite"]) == int((~np.isfinite(r)).sum())
    assert int(est.diagnostics["rejected_out_of_range"]) == int((r == 1e300).sum())  # beyond stepping.LIMITS.range
    assert np.all(np.isfinite(est.poses)) and np.all(np.isfinite(est.pose_cov))
