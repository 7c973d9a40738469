"""The pairwise consistency test of laser graph SLAM's loop closures (PCM): the chain's segment covariance and the
cycle's Mahalanobis distance against a literal composition with GTSAM's Jacobians, and the maximum consistent set
against planted inconsistent loops."""

from __future__ import annotations

import gtsam
import numpy as np
import pytest

from slamarena.datasets.geometry import between, compose
from slamarena.mapping.laser_slam.consistency import ConsistentSet, OdometryChain, cycle_mahalanobis, greedy_clique

CHI2_3_999 = 16.266


def _chain(n: int = 40, seed: int = 0) -> tuple[OdometryChain, list, list]:
    """A curving chain of n nodes with random per-factor covariances; returns it, its poses and factors (z, Σ)."""
    rng = np.random.default_rng(seed)
    chain, poses, factors = OdometryChain(), [np.array([3.0, -2.0, 0.4])], [None]
    chain.add(poses[0], None)
    for _ in range(1, n):
        z = np.array([0.5 + 0.2 * rng.random(), 0.1 * rng.standard_normal(), 0.15 * rng.standard_normal()])
        A = rng.standard_normal((3, 3)) * np.array([0.02, 0.02, 0.005])
        cov = A @ A.T + np.diag([1e-4, 1e-4, 1e-5])
        poses.append(compose(poses[-1], z))
        factors.append((z, cov))
        chain.add(poses[-1], cov)
    return chain, poses, factors


def _literal_segment(factors, p: int, q: int) -> tuple[gtsam.Pose2, np.ndarray]:
    """T_pq and its covariance composed factor by factor with GTSAM's Jacobians (inverted when q < p)."""
    lo, hi = min(p, q), max(p, q)
    T, cov = gtsam.Pose2(), np.zeros((3, 3))
    for z, c in factors[lo + 1 : hi + 1]:
        H1, H2 = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
        T = T.compose(gtsam.Pose2(*z), H1, H2)
        cov = H1 @ cov @ H1.T + H2 @ c @ H2.T
    if q < p:
        H1, H2 = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
        T = T.between(gtsam.Pose2(), H1, H2)  # T⁻¹
        cov = H1 @ cov @ H1.T
    return T, cov


@pytest.mark.parametrize(("p", "q"), [(3, 31), (31, 3), (0, 39), (17, 18), (12, 12)])
def test_chain_segment_covariance_equals_composing_with_gtsams_jacobians(p, q):
    chain, _, factors = _chain()
    T, cov = chain.relative(p, q)
    T_lit, cov_lit = _literal_segment(factors, p, q)
    np.testing.assert_allclose(T, [T_lit.x(), T_lit.y(), T_lit.theta()], atol=1e-9)
    np.testing.assert_allclose(cov, cov_lit, atol=1e-12)


def test_pairwise_mahalanobis_equals_the_literal_cycle():
    """d² of z_i⁻¹ T_{a_i a_j} z_j T_{n_j n_i} against composing the cycle with GTSAM's Jacobians."""
    chain, poses, factors = _chain()
    rng = np.random.default_rng(1)
    loops = []
    for a, n in ((2, 30), (5, 36), (33, 8)):
        z = compose(between(poses[a], poses[n]), np.array([0.05, -0.03, 0.02]) * rng.standard_normal(3))
        A = rng.standard_normal((3, 3)) * 0.03
        loops.append((a, n, z, A @ A.T + np.diag([1e-3, 2e-3, 1e-4])))
    for (a_i, n_i, z_i, c_i), (a_j, n_j, z_j, c_j) in (
        (loops[0], loops[1]),
        (loops[1], loops[2]),
        (loops[2], loops[0]),
    ):
        T_a, C_a = _literal_segment(factors, a_i, a_j)
        T_n, C_n = _literal_segment(factors, n_j, n_i)
        # Q = T_a · z_j · T_n, then E = z_i⁻¹ Q: every noise propagated by GTSAM's Jacobians, the four independent
        H = [np.zeros((3, 3), order="F") for _ in range(6)]
        Q1 = T_a.compose(gtsam.Pose2(*z_j), H[0], H[1])
        Q = Q1.compose(T_n, H[2], H[3])
        E = gtsam.Pose2(*z_i).between(Q, H[4], H[5])
        J_a, J_zj, J_n, J_zi = H[5] @ H[2] @ H[0], H[5] @ H[2] @ H[1], H[5] @ H[3], H[4]
        cov = J_a @ C_a @ J_a.T + J_zj @ c_j @ J_zj.T + J_n @ C_n @ J_n.T + J_zi @ c_i @ J_zi.T
        e = gtsam.Pose2.Logmap(E)
        literal = e @ np.linalg.solve(cov, e)
        ours = cycle_mahalanobis(chain, a_i, n_i, z_i, c_i, a_j, n_j, z_j, c_j)
        np.testing.assert_allclose(ours, literal, rtol=1e-9)
        assert 0.0 < literal < 40.0  # the noise of a right loop: not a degenerate case


def _loops_on_a_chain(shift: float):
    """A chain and 9 true loops (small noise) plus 4 false ones that agree with each other: each claims its node sits
    ``shift`` metres further along (a place that looks alike), the same claim everywhere."""
    chain, poses, _ = _chain(n=80, seed=2)
    rng = np.random.default_rng(3)
    cov = np.diag([0.03, 0.03, 0.01]) ** 2
    true = [(a, a + 50 + rng.integers(0, 5)) for a in range(2, 28, 3)]
    false = [(a, a + 51) for a in (4, 10, 16, 22)]
    loops = []
    for a, n in true:
        loops.append((a, n, compose(between(poses[a], poses[n]), rng.normal(0, [0.02, 0.02, 0.005])), cov, True))
    for a, n in false:
        loops.append((a, n, compose(between(poses[a], poses[n]), np.array([shift, 0.0, 0.0])), cov, False))
    order = rng.permutation(len(loops))
    return chain, [loops[i] for i in order]


def test_a_planted_consistent_group_of_false_loops_is_rejected():
    chain, loops = _loops_on_a_chain(shift=4.0)
    pcm = ConsistentSet(chain, CHI2_3_999)
    for a, n, z, cov, _ in loops:
        clique = pcm.add(a, n, z, cov)
    right = np.array([ok for *_, ok in loops])
    assert set(clique) == set(np.flatnonzero(right))
    # every false loop agrees with the other false ones and with no true one
    adj = pcm.adjacent
    f, t = np.flatnonzero(~right), np.flatnonzero(right)
    assert adj[np.ix_(f, f)].all() and not adj[np.ix_(f, t)].any() and adj[np.ix_(t, t)].all()


def test_a_small_claimed_shift_within_the_noise_stays_consistent():
    chain, loops = _loops_on_a_chain(shift=0.01)
    pcm = ConsistentSet(chain, CHI2_3_999)
    for a, n, z, cov, _ in loops:
        clique = pcm.add(a, n, z, cov)
    assert len(clique) == len(loops)


def test_the_larger_group_wins_whatever_arrives_first():
    """Three false loops first, then the five true ones: the clique switches to the true group once it is larger."""
    chain, loops = _loops_on_a_chain(shift=4.0)
    false = [x for x in loops if not x[4]][:3]
    true = [x for x in loops if x[4]][:5]
    pcm = ConsistentSet(chain, CHI2_3_999)
    sizes = []
    for a, n, z, cov, _ in false + true:
        sizes.append(len(pcm.add(a, n, z, cov)))
    assert sizes == [1, 2, 3, 3, 3, 3, 4, 5]
    assert set(pcm.clique) == {3, 4, 5, 6, 7}


def test_greedy_clique_on_a_known_graph():
    adj = np.zeros((6, 6), dtype=bool)
    for i, j in ((0, 1), (0, 2), (1, 2), (2, 3), (3, 4), (3, 5), (4, 5), (2, 4), (2, 5)):
        adj[i, j] = adj[j, i] = True
    np.testing.assert_array_equal(greedy_clique(adj, 3), [2, 3, 4, 5])
    np.testing.assert_array_equal(greedy_clique(adj, 0), [0, 1, 2])
