"""The deferred covariance update of EKF-SLAM equals the per-observation update and the literal reference.

``defer_covariance=True`` (the default) applies the N×N update of an observation set once, at
its end; ``False`` applies it after every observation (one pass over P each, the filter as it
was before the deferral). Both are run side by side on the same data, with unknown association,
rejected rows (outliers, non-finite rows, ambiguous rows) and landmarks created in the same set
after deferred updates, and the literal dense reference is fed the rows the filter applied, with
the landmark it chose for each.
"""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.geometry import wrap_angle
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.association import Decision
from slamarena.estimators.ekf_slam.checks import LANDMARK_BLOCK, NEGATIVE_DIAGONAL
from slamarena.estimators.ekf_slam.kernels import (
    APPLIED,
    NOT_FINITE,
    S_INDEFINITE,
    _projected_run,
    _rows_run,
    add_term_upper,
    correct_run,
    mirror_lower,
    update_lower,
)
from slamarena.estimators.ekf_slam.reference import ReferenceEKFSLAM
from slamarena.estimators.models import observe


@pytest.fixture(scope="module")
def sim():
    return datasets.load("sim:landmarks", n_landmarks=30, seed=2)


def _sets(seq, n_steps, rng):
    """(u, dt, z) per control row; z with an outlier row (a bearing 0.5 rad off) every 7th set and a NaN row every 11th."""
    mo, rb = seq.motion, seq.range_bearing
    for k in range(n_steps):
        z = rb.z[np.isclose(rb.t, mo.t[k] + mo.dt[k])]
        if len(z) and k % 7 == 3:
            bad = z[rng.integers(len(z))].copy()
            bad[1] = wrap_angle(bad[1] + 0.5)
            z = np.insert(z, rng.integers(len(z) + 1), bad, axis=0)
        if len(z) and k % 11 == 5:
            z = np.vstack([z, [np.nan, 0.0, 1.0]])
        yield (mo.v[k], mo.omega[k]), mo.dt[k], z


def _diff(a, b):
    d = np.asarray(a) - np.asarray(b)
    d[2] = wrap_angle(d[2])
    return np.abs(d).max()


CASES = [
    dict(use_ids=False),
    dict(use_ids=False, covariance_update="joseph", association="jcbb"),
    dict(use_ids=False, update="batch"),
    dict(use_ids=True, update="batch", covariance_update="joseph"),
    dict(use_ids=True),
]


@pytest.mark.parametrize("kw", CASES, ids=lambda kw: ",".join(f"{k}={v}" for k, v in kw.items()))
def test_deferred_update_equals_per_observation_update_and_reference(sim, kw):
    """300 steps: x and P of the deferred filter within 1e-9 of the per-observation filter and of the literal reference."""
    common = dict(
        initial_pose=sim.start_pose, twist_cov=sim.noise.twist_cov, range_bearing_cov=sim.noise.range_bearing_cov, **kw
    )
    deferred, immediate = EKFSLAM(**common), EKFSLAM(defer_covariance=False, **common)
    ref = ReferenceEKFSLAM(
        sim.noise.twist_cov,
        sim.noise.range_bearing_cov,
        initial_pose=sim.start_pose,
        **{k: v for k, v in kw.items() if k in ("covariance_update", "update")},
    )
    worst_imm = worst_ref = 0.0
    new_after_update = 0
    for k, (u, dt, z) in enumerate(_sets(sim, 300, np.random.default_rng(1))):
        for f in (deferred, immediate):
            f.predict(u, dt)
        ref.predict(u, dt)
        if len(z):
            seen = len(deferred.assoc_log)
            deferred.update(z)
            immediate.update(z)
            log = deferred.assoc_log[seen:]
            other = immediate.assoc_log[seen:]
            assert [(d, lm, g) for d, lm, _, g in log] == [(d, lm, g) for d, lm, _, g in other]  # the same decisions
            np.testing.assert_allclose([e[2] for e in log], [e[2] for e in other], rtol=1e-9)
            applied = [(j, lm) for j, (d, lm, _, _) in enumerate(log) if d != Decision.REJECTED]
            rows = z[np.all(np.isfinite(z), axis=1) & (z[:, 0] >= 0)]
            if applied:
                ref.update(np.column_stack([rows[[j for j, _ in applied], :2], [lm for _, lm in applied]]))
            kinds = [log[j][0] for j, _ in applied]
            new_after_update += any(Decision.NEW in kinds[i:] for i, d in enumerate(kinds) if d == Decision.MATCHED)
        worst_imm = max(worst_imm, _diff(deferred.x, immediate.x))
        worst_ref = max(worst_ref, _diff(deferred.x, ref.xEst))
        if k % 25 == 24:  # P read rarely: in between, the filters run on the stored lower triangle (upper half stale)
            worst_imm = max(worst_imm, np.abs(deferred.P - immediate.P).max())
            worst_ref = max(worst_ref, np.abs(deferred.P - ref.PEst).max())
    decisions = np.array([d for d, *_ in deferred.assoc_log])
    assert (
        deferred.n_landmarks >= 20
        and (decisions == Decision.REJECTED).sum() >= 10
        and deferred.rejected["nonfinite"] >= 10
    )
    assert new_after_update >= 3  # landmarks created in a set after (deferred) updates of the same set
    np.testing.assert_array_equal(deferred.P, deferred.P.T)
    assert worst_imm < 1e-9 and worst_ref < 1e-9, (worst_imm, worst_ref)


def test_a_failing_row_leaves_the_earlier_rows_of_its_set_applied(sim):
    """A row that raises mid-set (ideal Jacobians without the landmark's truth): the rows before it are in x and P, as without deferral."""
    lm = dict(zip(sim.landmarks.ids.tolist(), sim.landmarks.xy))
    pose = np.asarray(sim.start_pose, dtype=float)
    filters = [
        EKFSLAM(jacobians="ideal", defer_covariance=d, initial_pose=pose, initial_cov=[0.01, 0.01, 0.001])
        for d in (True, False)
    ]
    ids = list(lm)[:4]
    z0 = np.column_stack(
        [
            [np.hypot(*(lm[i] - pose[:2])) for i in ids],
            [wrap_angle(np.arctan2(*(lm[i] - pose[:2])[::-1]) - pose[2]) for i in ids],
            ids,
        ]
    )
    for f in filters:
        f.set_truth(pose=pose, landmarks=lm)
        f.update(z0)
        f.predict((0.5, 0.1), 0.5)
        f.set_truth(pose=f.x[:3], landmarks={i: lm[i] for i in ids[:2]})  # no truth for ids[2:]: their rows raise
        with pytest.raises(ValueError, match="true position"):
            f.update(z0 + [[0.05, 0.01, 0]] * 4)
    (a, b) = filters
    assert len(a.nis_log) == len(b.nis_log) == 2  # the two rows before the failing one applied, none after
    np.testing.assert_allclose(a.nis_log, b.nis_log, rtol=1e-12)  # deferral changes the result only by rounding
    np.testing.assert_allclose(a.x, b.x, atol=1e-12)
    np.testing.assert_allclose(a.P, b.P, atol=1e-12)
    np.testing.assert_array_equal(a.P, a.P.T)


def _run_inputs(sim, pending, current, seed):
    """A filter after 400 steps of sim, its storage with a pending term from a first run of 3 rows (``pending``), and the
    inputs of a run of 8 rows of mapped landmarks (H at the current estimate, or at perturbed linearisation points)."""
    ekf = EKFSLAM(initial_pose=np.asarray(sim.start_pose, dtype=float), initial_cov=[0.01, 0.01, 0.001])
    for u, dt, z in _sets(sim, 400, np.random.default_rng(seed)):
        ekf.predict(u, dt)
        ekf.update(z)
    s, rng = ekf._s, np.random.default_rng(seed)
    R = np.diag([0.1**2, np.radians(2.0) ** 2])
    slots = rng.choice(ekf.n_landmarks, 11, replace=False).astype(np.int64)

    def rows(slots):
        Z = observe(s.x[:3], s.x[3:].reshape(-1, 2)[slots]) + rng.normal(size=(slots.size, 2)) * [0.1, np.radians(2.0)]
        XL = s.x[:3] + rng.normal(size=(slots.size, 3)) * 0.05
        ML = s.x[3:].reshape(-1, 2)[slots] + rng.normal(size=(slots.size, 2)) * 0.05
        return XL, ML, np.ascontiguousarray(Z), np.ascontiguousarray(np.broadcast_to(R, (slots.size, 2, 2)))

    s._reserve(2 * 11)
    s._refresh_stored_entries()
    if pending:
        assert s.correct_run(slots[:3], *rows(slots[:3])[:2], current, *rows(slots[:3])[2:], False)[0] == 3
    return s, slots[3:], rows(slots[3:])


def _state(s):
    return dict(
        x=s._x.copy(),
        Ut=s._Ut.copy(),
        Ust=s._Ust.copy(),
        sg=s._sg.copy(),
        pend=tuple(a.copy() for a in s._pending),
        stored=tuple(a.copy() for a in s._stored_entries),
    )


def _call(kernel, s, state, slots, inputs, current, *extra):
    XL, ML, Z, R = inputs
    return kernel(
        s._P,
        s.n,
        state["Ut"],
        state["Ust"],
        state["sg"],
        s._r,
        state["pend"],
        state["stored"],
        state["x"][: s.n],
        slots,
        XL,
        ML,
        current,
        Z,
        R,
        *extra,
    )


@pytest.mark.parametrize("pending", [False, True], ids=["no term pending", "a term pending"])
@pytest.mark.parametrize("current", [True, False], ids=["H at the current estimate", "H at given points"])
def test_the_projected_run_equals_the_row_by_row_run(sim, pending, current):
    """correct_run's standard form in the span of the rows' H_j P_0 (one read of P per row, the term formed at the end)
    against the row-by-row form on the same inputs: the rows applied, their NIS and Jacobians, x, the term's rows
    (each W_j), its signs and its checked entries, to rounding."""
    s, slots, inputs = _run_inputs(sim, pending, current, seed=3)
    a, b = _state(s), _state(s)
    got = _call(_projected_run, s, a, slots, inputs, current, 3)
    want = _call(_rows_run, s, b, slots, inputs, current, False, 3)
    assert (
        got[-1]
        and got[0] == want[0] == slots.size
        and got[1] == want[1] == s._r + 2 * slots.size
        and got[2] == want[2] == APPLIED
    )
    np.testing.assert_allclose(got[5], want[5], rtol=1e-9)  # NIS
    np.testing.assert_allclose(got[6], want[6], rtol=1e-9, atol=1e-12)  # H
    np.testing.assert_allclose(a["x"], b["x"], rtol=0, atol=1e-12)
    rows = slice(s._r, want[1])
    scale = np.abs(b["Ut"][rows]).max()
    np.testing.assert_allclose(a["Ut"][rows, : s.n], b["Ut"][rows, : s.n], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(a["Ust"][rows, : s.n], b["Ust"][rows, : s.n], rtol=0, atol=1e-9 * scale)
    np.testing.assert_array_equal(a["sg"][rows], b["sg"][rows])
    for p, q in zip(a["pend"], b["pend"]):
        np.testing.assert_allclose(p, q, rtol=0, atol=1e-9 * max(1e-12, np.abs(q).max()))


@pytest.mark.parametrize("failure", ["negative diagonal", "indefinite S", "non-finite row"])
def test_a_run_that_fails_a_check_stops_where_the_row_by_row_run_stops(sim, failure):
    """A run whose row 4 of 8 fails: a landmark's variance that row 4's term makes negative (the projected run's one check
    at the end fails, and the rows are run one by one to find the row), an indefinite S (R of row 4 negative),
    a non-finite observation. correct_run stops where the row-by-row run stops, with the same outcome and state."""
    s, slots, (XL, ML, Z, R) = _run_inputs(sim, True, True, seed=4)
    if failure == "negative diagonal":  # the cached block of row 4's landmark before the run: P[e, e] between what rows
        # 0 … 3 and rows 0 … 4 take from it, P[e + 1, e + 1] = 1, P[e + 1, e] = 0
        e = 3 + 2 * slots[4]
        probe = _state(s)
        _call(_rows_run, s, probe, slots, (XL, ML, Z, R), True, False, 3)
        taken = np.cumsum((probe["Ut"][s._r : s._r + 2 * slots.size, e] ** 2).reshape(-1, 2).sum(axis=1))
        sd, _, so = s._stored_entries
        sd[e], sd[e + 1], so[slots[4]] = -s._pending[0][e] + 0.5 * (taken[3] + taken[4]), 1.0, -s._pending[2][slots[4]]
    elif failure == "indefinite S":
        R = R.copy()
        R[4] = -np.eye(2)
    else:
        Z = Z.copy()
        Z[4, 0] = np.inf
    a, b = _state(s), _state(s)
    inputs = (XL, ML, Z, R)
    got = _call(correct_run, s, a, slots, inputs, True, False, 3)
    want = _call(_rows_run, s, b, slots, inputs, True, False, 3)
    code = {
        "negative diagonal": (NEGATIVE_DIAGONAL, LANDMARK_BLOCK),
        "indefinite S": (S_INDEFINITE,),
        "non-finite row": (NOT_FINITE,),
    }[failure]
    assert want[2] in code and got[0] == want[0] and got[1] == want[1] and got[2] == want[2] and got[3] == want[3]
    assert want[0] == 4
    if failure != "negative diagonal":
        assert _call(_projected_run, s, _state(s), slots, inputs, True, 3)[-1]  # found without the row-by-row pass
    else:
        assert not _call(_projected_run, s, _state(s), slots, inputs, True, 3)[-1]  # the end's check fails
    np.testing.assert_allclose(got[5], want[5], rtol=1e-9)
    np.testing.assert_allclose(a["x"], b["x"], rtol=0, atol=1e-12)
    for p, q in zip(a["pend"], b["pend"]):
        np.testing.assert_allclose(p, q, rtol=0, atol=1e-9 * max(1e-12, np.abs(q).max()))


@pytest.mark.parametrize("n, r", [(1603, 20), (515, 7), (5, 3), (1025, 0)])
def test_the_term_added_to_the_upper_entries_is_the_literal_one(n, r):
    """add_term_upper: the robot rows P[a, i > a] receive (Ustᵀ Ut)[a, i] (summed in blocks of columns, block edges
    included), each landmark block's P[s, s + 1] its pending entry, and nothing else changes."""
    rng = np.random.default_rng(n + r)
    capacity = n + 9
    P = rng.normal(size=(capacity, capacity))
    Ut, Ust = (
        rng.normal(size=(r + 2, capacity)),
        rng.normal(size=(r + 2, capacity)),
    )  # rows beyond r are not part of the term
    off = rng.normal(size=capacity // 2)
    expected = P.copy()
    term = Ust[:r, :3].T @ Ut[:r, :n]  # (3, n)
    for a in range(3):
        expected[a, a + 1 : n] += term[a, a + 1 :]
    s = np.arange(3, n - 1, 2)
    expected[s, s + 1] += off[: s.size]
    add_term_upper(P, n, Ut, Ust, r, off)
    np.testing.assert_allclose(P, expected, rtol=0, atol=1e-12 * max(1.0, np.abs(term).max()))
    changed = np.zeros_like(P, dtype=bool)
    for a in range(3):
        changed[a, a + 1 : n] = True
    changed[s, s + 1] = True
    np.testing.assert_array_equal(P[~changed], expected[~changed])


@pytest.mark.parametrize(
    "n, capacity, d, mixed",
    [
        (50, 64, 20, False),
        (61, 64, 12, True),
        (301, 512, 7, False),
        (3, 8, 6, True),
        (40, 48, 2, False),
        (9, 9, 4, True),
    ],
)
def test_lower_update_in_place_on_the_live_block(n, capacity, d, mixed):
    """The lower triangle of P[:n, :n] += C diag(s) Cᵀ (fused loop or BLAS on the strided live block and factor), then the mirror copy:
    exact to rounding, bitwise symmetric, the rest of the buffer untouched."""
    rng = np.random.default_rng(n)
    A = rng.normal(size=(capacity, capacity))
    buffer = A @ A.T
    C = rng.normal(size=(n, d))
    s = -np.ones(d)
    if mixed:
        s[::3], s[1::3] = 0.5, -0.5
    before = buffer.copy()
    expected = buffer.copy()
    expected[:n, :n] += (C * s) @ C.T
    Ct = np.full((d, capacity + 5), np.nan)  # Cᵀ as the filter passes it: the first n columns of wider rows
    Ct[:, :n] = C.T
    update_lower(buffer, n, Ct[:, :n], s)
    np.testing.assert_array_equal(np.triu(buffer[:n, :n], 1), np.triu(before[:n, :n], 1))  # the upper half untouched
    mirror_lower(buffer, n)
    np.testing.assert_allclose(buffer, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_array_equal(buffer[:n, :n], buffer[:n, :n].T)
    np.testing.assert_array_equal(buffer[n:], expected[n:])
    np.testing.assert_array_equal(buffer[:, n:], expected[:, n:])


def test_the_carried_checked_entries_are_the_stored_covariance_s(sim):
    """The flush adds each set's term to the cached checked entries instead of re-reading them: after a few hundred
    sets without a full read of P, they still equal the stored P's own (diagonal, robot block, landmark off-diagonals)
    up to rounding."""
    from slamarena.estimators.ekf_slam.checks import covariance_entries

    ekf = EKFSLAM(initial_pose=np.asarray(sim.start_pose, dtype=float), initial_cov=[0.01, 0.01, 0.001])
    carried = 0
    for u, dt, z in _sets(sim, 300, np.random.default_rng(0)):
        ekf.predict(u, dt)
        n_before = ekf.n_landmarks
        ekf.update(z)
        carried += ekf.n_landmarks == n_before and ekf._s._stored_valid
    assert carried > 100  # most sets carried the entries (a growth re-reads them)
    for cached, stored in zip(ekf._s.entries(), covariance_entries(ekf._s.view)):
        np.testing.assert_allclose(cached, stored, rtol=1e-9, atol=1e-15)


def test_columns_read_the_current_covariance_with_a_term_pending(sim):
    """GrowingState.columns (a new landmark's read of P) against the whole current P: robot and
    landmark columns, unsorted and repeated, read from the stored lower triangle and robot rows plus a pending term."""
    ekf = EKFSLAM(initial_pose=np.asarray(sim.start_pose, dtype=float), initial_cov=[0.01, 0.01, 0.001])
    for u, dt, z in _sets(sim, 60, np.random.default_rng(1)):
        ekf.predict(u, dt)
        ekf.update(z)
    s = ekf._s
    N = s.n
    rng = np.random.default_rng(2)
    s._reserve(4)
    s._Ut[:4, :N] = rng.normal(size=(4, N))  # a pending term Ustᵀ Ut of rank 4
    s._Ust[:4, :N] = s._Ut[:4, :N] * np.array([-1.0, 0.5, -0.5, -1.0])[:, None]
    s._r = 4
    idx = [N - 1, 0, 4, 3, 2, 0, 7, 8, N - 2]
    got = s.columns(idx)
    s._r = 0
    full = s.P.copy()  # the stored P, mirrored
    expected = full[:, idx] + s._Ust[:4, :N].T @ s._Ut[:4, idx]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
