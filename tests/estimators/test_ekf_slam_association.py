"""EKF-SLAM data association: vectorised compatibility, NN on a separated map, JCBB where NN fails."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam import association as assoc
from slamarena.estimators.ekf_slam.association import Decision
from slamarena.estimators.models import chi2_gate, observation_jacobians, observe


def test_vectorised_compatibility_and_pair_d2_match_dense_per_pair_computation():
    rng = np.random.default_rng(3)
    n, M = 6, 4
    x = np.r_[0.3, -0.2, 0.5, rng.uniform(-6, 6, 2 * n)]
    A = rng.normal(size=(x.size, x.size))
    P = A @ A.T / x.size
    z = np.column_stack([rng.uniform(1, 8, M), rng.uniform(-3, 3, M)])
    R = np.array([np.diag([0.04, 0.003 * (j + 1)]) for j in range(M)])  # per-observation noise
    nu, S, d2 = assoc.compatibility(x, P, R, z)
    slots = rng.integers(0, n, M)  # the compiled per-pair gate agrees with the table
    np.testing.assert_allclose(assoc.pair_d2(x, P, R, z, slots), d2[np.arange(M), slots], rtol=1e-12)
    for i in range(n):
        H = np.zeros((2, x.size))
        H[:, :3], H[:, 3 + 2 * i : 5 + 2 * i] = observation_jacobians(x[:3], x[3 + 2 * i : 5 + 2 * i])
        for j in range(M):
            S_dense = H @ P @ H.T + R[j]
            np.testing.assert_allclose(S[j, i], S_dense, rtol=1e-12)
            v = z[j] - observe(x[:3], x[3 + 2 * i : 5 + 2 * i])
            v[1] = (v[1] + np.pi) % (2 * np.pi) - np.pi
            np.testing.assert_allclose(d2[j, i], v @ np.linalg.solve(S_dense, v), rtol=1e-9)


@pytest.mark.parametrize("method", ["nn", "jcbb"])
def test_unknown_association_recovers_the_landmarks_of_a_separated_map(method):
    """Ids withheld on a 7 m lattice: one landmark per true landmark, every match consistent with the truth."""
    seq = datasets.load("sim:landmarks", n_landmarks=25, layout="grid", density=0.03, seed=0)
    est = EKFSLAM(use_ids=False, association=method).run(seq)
    d = est.diagnostics
    dec, lm, given = d["assoc_decision"], d["assoc_landmark"], d["assoc_given_id"]
    assert est.meta["n_landmarks"] == np.unique(seq.range_bearing.landmark_id).size
    creator = dict(zip(lm[dec == Decision.NEW], given[dec == Decision.NEW]))
    assert len(set(creator.values())) == len(creator)  # no true landmark created twice
    matched = dec == Decision.MATCHED
    assert matched.mean() > 0.85
    assert all(creator[a] == g for a, g in zip(lm[matched], given[matched]))
    assert np.all(lm[dec == Decision.REJECTED] == -1) and not np.isnan(d["assoc_d2"]).any()
    # every observation got a decision, in time order with its stamp
    assert dec.size == len(seq.range_bearing) and np.all(np.diff(d["assoc_t"]) >= 0)


def _row_scene(method: str):
    """Five landmarks 2 m apart on the line y = 10 m (to the robot's left); the robot believes x = 0 (σ_x = 1 m) but stands at x = 1.2.

    Every observation then looks 0.8 m from its left neighbour and 1.2 m from its own
    landmark, so individually the left neighbour is nearer; jointly, only the true pairing
    explains all five observations with one robot displacement.
    """
    L = np.column_stack([2.0 * np.arange(5), np.full(5, 10.0)])
    ekf = EKFSLAM(association=method, initial_cov=[1e-8] * 3, twist_cov=[1.0, 1e-12], range_bearing_cov=[1e-2, 1e-4])
    ekf.update(np.column_stack([observe(np.zeros(3), L), np.arange(5)]))
    ekf.predict((0.0, 0.0), 1.0)  # robot x variance += 1 m², mean unchanged
    z = observe(np.array([1.2, 0.0, 0.0]), L)
    return ekf, np.column_stack([z, np.full(5, -1.0)])


def test_nearest_neighbour_misassociates_the_row_scene():
    ekf, z = _row_scene("nn")
    ekf.update(z)
    matched = [lm for dec, lm, _, _ in ekf.assoc_log[5:]]
    assert matched == [0, 0, 1, 2, 3]  # each observation (but the first) taken for its left neighbour
    assert ekf.x[0] < 0.0  # and the robot corrected the wrong way


def test_jcbb_associates_the_row_scene_correctly():
    ekf, z = _row_scene("jcbb")
    ekf.update(z)
    log = ekf.assoc_log[5:]
    assert [dec for dec, _, _, _ in log] == [Decision.MATCHED] * 5
    assert [lm for _, lm, _, _ in log] == [0, 1, 2, 3, 4]
    assert abs(ekf.x[0] - 1.2) < 0.01  # the robot moved to where it truly is


def test_decisions_new_and_rejected_follow_the_two_gates():
    d2 = np.array([[1.0, 50.0], [8.0, 40.0], [30.0, 45.0]])
    g_match, g_new = chi2_gate(0.95, 2), chi2_gate(0.99999, 2)
    a = assoc.nearest_neighbour(d2, g_match, g_new)
    np.testing.assert_array_equal(a.decision, [Decision.MATCHED, Decision.REJECTED, Decision.NEW])
    np.testing.assert_array_equal(a.slot, [0, -1, -1])
    assert abs(g_match - 5.991464547) < 1e-6


def _literal_book_counts(seen, quality, managed, born, matched, visible, t, sightings, window, miss_limit):
    """LandmarkBook.observe's rules written with whole-array numpy operations (the compiled pass is checked against it)."""
    seen, quality = seen.copy(), quality.copy()
    np.add.at(seen, matched, 1)
    hit = np.zeros(seen.size, dtype=bool)
    hit[matched] = True
    quality[hit] += 1
    if miss_limit is not None:
        quality[visible & ~hit] -= 1
    unconfirmed = managed & (seen < sightings) & (t - born > window)
    lost = managed & (quality < -miss_limit) if miss_limit is not None else np.zeros_like(unconfirmed)
    return seen, quality, np.flatnonzero(unconfirmed | lost), int(unconfirmed.sum()), int((lost & ~unconfirmed).sum())


@pytest.mark.parametrize("miss_limit", [None, 2])
def test_the_landmark_book_counts_as_its_literal_rules(miss_limit):
    """The compiled counting pass of LandmarkBook.observe against the rules written out: sightings (a slot matched twice in
    a set counts twice), quality, and the unconfirmed and lost slots to remove, over random books and sets."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        n = int(rng.integers(1, 30))
        book = assoc.LandmarkBook(3, 10.0, miss_limit, 20.0 if miss_limit is not None else None, np.pi)
        book.managed, book.born = rng.uniform(size=n) < 0.7, rng.uniform(0, 20, n)
        book.seen, book.quality = rng.integers(1, 5, n), rng.integers(-4, 4, n)
        matched = rng.integers(0, n, int(rng.integers(0, 6)))
        predicted = np.column_stack([rng.uniform(0, 30, n), rng.uniform(-np.pi, np.pi, n)])
        predicted[rng.uniform(size=n) < 0.2] = np.nan  # created in this set
        with np.errstate(invalid="ignore"):
            visible = (predicted[:, 0] < 20.0) & (np.abs(predicted[:, 1]) < 0.5 * np.pi)
        seen, quality, remove, unconfirmed, lost = _literal_book_counts(
            book.seen, book.quality, book.managed, book.born, matched, visible, 21.0, 3, 10.0, miss_limit
        )
        got = book.observe(21.0, matched, predicted if miss_limit is not None else None)
        np.testing.assert_array_equal(got, remove)
        np.testing.assert_array_equal(book.seen, seen)
        np.testing.assert_array_equal(book.quality, quality)
        assert book.removed == {"unconfirmed": unconfirmed, "quality": lost}


def test_landmark_management_confirms_removes_and_marginalises():
    """A standing robot, ids withheld: tree A seen in every set, a single spurious detection B behind the robot (outside the
    sensor's field, so only the window can remove it), tree C seen three times and then missed while in view. B is removed
    as unconfirmed once the window has passed, C by the quality counter once it falls below −miss_limit; A is confirmed and
    kept. A removal marginalises: the other entries of x and P are those before it."""
    ekf = EKFSLAM(
        use_ids=False,
        confirm_sightings=3,
        confirm_window=10.0,
        miss_limit=2,
        sensor_range=20.0,
        sensor_fov=np.pi,
        initial_cov=[1e-4, 1e-4, 1e-6],
    )
    A, B, C = np.array([5.0, 0.0]), 5.0 * np.array([np.cos(2.0), np.sin(2.0)]), np.array([9.0, -4.0])

    def rows(*points):
        return np.column_stack([observe(np.zeros(3), np.array(points)), np.full(len(points), -1)])

    ekf.update(rows(A, B), t=0.0)
    assert ekf.n_landmarks == 2 and not ekf.confirmed.any()
    for t in range(1, 11):
        ekf.update(rows(A), t=float(t))
    assert ekf.n_landmarks == 2 and ekf.confirmed.tolist() == [True, False]  # B's window has not passed (10 − 0 ≯ 10)
    ekf.update(rows(A), t=11.0)
    assert ekf.n_landmarks == 1 and ekf.book.removed == {"unconfirmed": 1, "quality": 0}
    for t in (12.0, 13.0, 14.0):  # C created, seen twice more: confirmed
        ekf.update(rows(A, C), t=t)
    assert ekf.n_landmarks == 2 and ekf.confirmed.all()
    for t in (15.0, 16.0, 17.0, 18.0):  # C's quality 2 → −2: still kept
        ekf.update(rows(A), t=t)
    assert ekf.n_landmarks == 2
    ekf.update(rows(A), t=19.0)  # −3 < −2: removed
    assert ekf.n_landmarks == 1 and ekf.book.removed == {"unconfirmed": 1, "quality": 1}
    assert np.linalg.norm(ekf.x[3:5] - A) < 0.05

    ekf.update(rows(C), t=20.0)  # marginalising a slot directly
    x, P = ekf.x.copy(), ekf.P.copy()
    ekf._remove_landmarks(np.array([0]))
    keep = [0, 1, 2, 5, 6]
    np.testing.assert_array_equal(ekf.x, x[keep])
    np.testing.assert_array_equal(ekf.P, P[np.ix_(keep, keep)])


def _lost_robot_scene() -> datasets.Sequence:
    """Three landmarks on y = 30 m, A (0, 30), B (4, 30), C (12, 30), mapped at t = 0 from labelled rows by a robot that is
    sure of its pose. Its odometry then says it stood still (σ_x = 3 m) while it moved 3 m ahead, and from t = 1 on it moves
    0.5 m per step and sees one landmark per set, without ids: B at t = 1, C at t = 2, 3, B at t = 4, C at t = 5, ….

    Alone, the row of B at t = 1 lies 1 m from A and 3 m from B where the robot believes it is (d² 0.12 against 1.9 with
    σ_x = 3 m): nearest neighbour (and JCBB, one row) takes it for A, the robot jumps to x ≈ −1, and C is then 4 m from
    where its observation lands — a duplicate of C. The hypothesis "B" is the one the following sets agree with."""
    from slamarena.datasets.sequence import Increments, RangeBearing, Sequence

    L = np.array([[0.0, 30.0], [4.0, 30.0], [12.0, 30.0]])
    steps = 8
    x_true = np.r_[0.0, 3.0 + 0.5 * np.arange(steps)]  # at t = 0, 1, …, steps
    delta = np.column_stack(
        [np.r_[0.0, np.full(steps - 1, 0.5)], np.zeros(steps), np.zeros(steps)]
    )  # odometry to t = 1 … steps
    cov = np.array([np.diag([9.0 if k == 0 else 1e-4, 1e-6, 1e-6]) for k in range(steps)])
    seen = [None] + [1, 2, 2, 1, 2, 2, 1, 2][:steps]
    rows = [(0.0, *observe(np.zeros(3), L[i]), i) for i in range(3)]
    rows += [(float(k), *observe(np.array([x_true[k], 0.0, 0.0]), L[seen[k]]), -1) for k in range(1, steps + 1)]
    t, r, b, ids = (np.array(c) for c in zip(*rows))
    return Sequence(
        "lost robot",
        motion=Increments(t=np.arange(1.0, steps + 1), delta=delta, cov=cov),
        range_bearing=RangeBearing(t=t, range=r, bearing=b, landmark_id=ids.astype(np.int64)),
        initial_pose=np.zeros(3),
    )


@pytest.mark.parametrize("method", ["nn", "jcbb"])
def test_the_look_ahead_decides_an_ambiguous_row_by_the_sets_that_follow(method):
    seq = _lost_robot_scene()
    params = dict(association=method, range_bearing_cov=[1e-2, 1e-4], initial_cov=[1e-10] * 3, confirm_sightings=1)
    plain, ahead = EKFSLAM(**params, window=0).run(seq), EKFSLAM(**params, window=3).run(seq)
    for est in (plain, ahead):
        assert est.diagnostics["assoc_t"][3] == 1.0 and est.diagnostics["assoc_given_id"][3] == -1
    lm, dec = plain.diagnostics["assoc_landmark"], plain.diagnostics["assoc_decision"]
    assert lm[3] == 0 and dec[3] == Decision.MATCHED  # one set: B taken for A
    assert plain.meta["n_landmarks"] == 4 and plain.meta["looked_ahead"] == 0  # and C mapped twice
    assert abs(plain.poses[-1, 0] - (3.0 + 0.5 * 7)) > 2.0
    lm, dec = ahead.diagnostics["assoc_landmark"], ahead.diagnostics["assoc_decision"]
    assert ahead.meta["looked_ahead"] >= 1 and ahead.diagnostics["looked_ahead_t"][0] == 1.0
    np.testing.assert_array_equal(lm[3:], [1, 2, 2, 1, 2, 2, 1, 2])  # the window: B, then every row its own landmark
    assert np.all(dec[3:] == Decision.MATCHED) and ahead.meta["n_landmarks"] == 3
    assert abs(ahead.poses[-1, 0] - (3.0 + 0.5 * 7)) < 0.05


def test_an_unambiguous_row_is_not_looked_ahead_and_the_window_changes_nothing_then():
    """On the separated lattice no row is ambiguous: with a window the run is the run without one."""
    seq = datasets.load("sim:landmarks", n_landmarks=25, layout="grid", density=0.03, seed=0)
    plain, ahead = EKFSLAM(use_ids=False, window=0).run(seq), EKFSLAM(use_ids=False, window=5).run(seq)
    assert ahead.meta["looked_ahead"] == 0
    np.testing.assert_array_equal(plain.poses, ahead.poses)
    np.testing.assert_array_equal(plain.diagnostics["assoc_landmark"], ahead.diagnostics["assoc_landmark"])


def test_hypotheses_are_the_compatible_landmarks_by_posterior_then_not_in_the_map():
    S = np.broadcast_to(np.eye(2), (2, 3, 2, 2))
    d2 = np.array([[0.2, 1.0, 9.0], [0.1, 60.0, 70.0]])  # row 0: two landmarks inside the match gate
    R = np.broadcast_to(0.01 * np.eye(2), (2, 2, 2))
    g_match, g_new = chi2_gate(0.95, 2), chi2_gate(0.99999, 2)
    log_lam, log_new = assoc.log_densities(S, d2, R, g_new)
    np.testing.assert_allclose(log_lam, -0.5 * d2 - np.log(2 * np.pi))
    np.testing.assert_allclose(log_new, -0.5 * g_new - 0.5 * np.log(1e-4) - np.log(2 * np.pi))
    row, options = assoc.hypotheses(log_lam, log_new, d2, g_match, 0.95, 3)
    assert row == 0
    np.testing.assert_array_equal(options, [0, 1, -1])
    assert (
        assoc.hypotheses(log_lam[1:], log_new[1:], d2[1:], g_match, 0.95, 3) is None
    )  # row 1 alone: p(landmark 0) ≈ 1
