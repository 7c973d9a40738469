"""EKF-SLAM data association: vectorised compatibility, NN on a separated map, JCBB where NN fails."""
from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam import association as assoc
from slamarena.estimators.ekf_slam.association import Decision
from slamarena.estimators.models import observation_jacobians, observe


def test_vectorised_compatibility_and_pair_d2_match_dense_per_pair_computation():
    rng = np.random.default_rng(3)
    n, M = 6, 4
    x = np.r_[0.3, -0.2, 0.5, rng.uniform(-6, 6, 2 * n)]
    A = rng.normal(size=(x.size, x.size))
    P = A @ A.T / x.size
    z = np.column_stack([rng.uniform(1, 8, M), rng.uniform(-3, 3, M)])
    R = np.array([np.diag([0.04, 0.003 * (j + 1)]) for j in range(M)])  # per-observation noise
    nu, S, d2 = assoc.compatibility(x, P, R, z)
    slots = rng.integers(0, n, M)                                    # the compiled per-pair gate agrees with the table
    np.testing.assert_allclose(assoc.pair_d2(x, P, R, z, slots), d2[np.arange(M), slots], rtol=1e-12)
    for i in range(n):
        H = np.zeros((2, x.size))
        H[:, :3], H[:, 3 + 2 * i: 5 + 2 * i] = observation_jacobians(x[:3], x[3 + 2 * i: 5 + 2 * i])
        for j in range(M):
            S_dense = H @ P @ H.T + R[j]
            np.testing.assert_allclose(S[j, i], S_dense, rtol=1e-12)
            v = z[j] - observe(x[:3], x[3 + 2 * i: 5 + 2 * i])
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
    g_match, g_new = assoc.chi2_gate(0.95, 2), assoc.chi2_gate(0.99999, 2)
    a = assoc.nearest_neighbour(d2, g_match, g_new)
    np.testing.assert_array_equal(a.decision, [Decision.MATCHED, Decision.REJECTED, Decision.NEW])
    np.testing.assert_array_equal(a.slot, [0, -1, -1])
    assert abs(g_match - 5.991464547) < 1e-6
