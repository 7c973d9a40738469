"""Observability of the linearised EKF-SLAM system (Huang, Mourikis & Roumeliotis 2010) and the OC-EKF.

The nonlinear 2D SLAM system has a three-dimensional unobservable subspace (global translation and
rotation). The observability matrix of the system the filter linearised,
``M = [H_1; H_2 Φ_1; H_3 Φ_2 Φ_1; …]`` (H_k the measurement Jacobians it used at step k, Φ_k the
transition it used from k to k + 1, both over the whole state), is built here from the Jacobians
the filter actually applied (recorded by wrapping its two sources: the displacements of the
prediction chain and the measurement Jacobians). Standard Jacobians give a nullspace of dimension 2
only (the spurious heading information); FEJ and OC keep 3, spanned by the directions
``N = [[I₂, J p̆_R], [0, 1], [I₂, J p̆_L1], …]`` at their linearisation points.
"""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.models import observe
from slamarena.experiments.metrics.consistency import monte_carlo, nees
from slamarena.experiments.metrics.reference import reference_of

LANDMARKS = np.array([[4.0, 1.0], [1.0, 5.0], [-3.0, 2.0], [0.5, -4.0]])


def _observability_matrix(jacobians: str, steps: int = 40, seed: int = 0, **params) -> tuple[np.ndarray, EKFSLAM]:
    """M over the state after the first set (all four landmarks mapped then), from the Jacobians the filter used."""
    rng = np.random.default_rng(seed)
    ekf = EKFSLAM(
        jacobians=jacobians, twist_cov=[0.01, 0.01], range_bearing_cov=[0.01, 0.003], initial_cov=0.0, **params
    )
    n_state = 3 + 2 * len(LANDMARKS)
    record: list = []
    chain, correct_run = ekf._s.predict_chain, ekf._s.correct_run

    def recording_chain(*args):
        out = chain(*args)
        record.append(("Φ", out[2].sum(axis=0)))  # ΣD of the chain: Φ = I + [[0, 0, −ΣD_y], [0, 0, ΣD_x], 0]
        return out

    def recording_run(slots, *args):
        out = correct_run(slots, *args)
        applied, H = out[0], out[5]  # the Jacobians [H_x, H_m] each applied row was linearised with
        record.append(("H", slots[:applied].copy(), H[:, :, :3].copy(), H[:, :, 3:].copy()))
        return out

    ekf._s.correct_run, ekf._s.predict_chain = recording_run, recording_chain
    true = np.zeros(3)
    for k in range(steps + 1):
        if k:
            u = np.array([1.0, 0.4])
            dt = 0.2
            true = true + np.array([u[0] * dt * np.cos(true[2]), u[0] * dt * np.sin(true[2]), u[1] * dt])
            ekf.predict(u + rng.normal(0.0, 0.1, 2), dt)
        z = observe(true, LANDMARKS) + rng.normal(0.0, [0.1, 0.05], (len(LANDMARKS), 2))
        ekf.update(np.column_stack([z, np.arange(len(LANDMARKS))]))
        if k == 0:
            record.clear()  # the first set maps the landmarks; M starts from the full state
    rows, T = [], np.eye(n_state)
    for entry in record:
        if entry[0] == "Φ":
            Phi = np.eye(n_state)
            Phi[0, 2], Phi[1, 2] = -entry[1][1], entry[1][0]
            T = Phi @ T
        else:
            _, slots, Hx, Hm = entry
            for s, hx, hm in zip(slots, Hx, Hm):
                H = np.zeros((2, n_state))
                H[:, :3], H[:, 3 + 2 * s : 5 + 2 * s] = hx, hm
                rows.append(H @ T)
    return np.vstack(rows), ekf


def _nullity(M: np.ndarray) -> int:
    s = np.linalg.svd(M, compute_uv=False)
    return int(np.sum(s < 1e-9 * s[0]))


def test_standard_jacobians_gain_a_spurious_observable_direction_fej_and_oc_keep_three():
    M_std, _ = _observability_matrix("standard")
    assert _nullity(M_std) == 2
    for mode in ("fej", "oc"):
        M, ekf = _observability_matrix(mode)
        assert _nullity(M) == 3, mode
        # the nullspace is the translation and the rotation about the linearisation points at the start of M
        J = np.array([[0.0, -1.0], [1.0, 0.0]])
        anchors = ekf._first[: len(LANDMARKS)]
        N = np.zeros((M.shape[1], 3))
        N[:2, :2] = np.eye(2)
        N[2, 2] = 1.0
        for i, m in enumerate(anchors):
            N[3 + 2 * i : 5 + 2 * i, :2] = np.eye(2)
            N[3 + 2 * i : 5 + 2 * i, 2] = J @ m
        # the robot rows of the rotation direction: M's first step is at the robot anchor of that step, found from M itself
        rot = np.linalg.lstsq(M[:, :2], -M[:, 3:] @ N[3:, 2] - M[:, 2], rcond=None)[0]
        N[:2, 2] = rot
        assert np.abs(M @ N).max() < 1e-9 * np.abs(M).max(), mode
    # standard: the rotation about any point is observed
    assert np.linalg.svd(M_std, compute_uv=False)[-3] > 1e-6


def test_oc_linearisation_points_stay_closer_to_the_estimates_than_fej():
    """OC chooses the robot anchor by least squares: its relative vectors deviate less from the estimates' than FEJ's (the
    published filters: no linearisation point set again, anchor_confidence=None)."""
    _, fej = _observability_matrix("fej", seed=3, anchor_confidence=None)
    _, oc = _observability_matrix("oc", seed=3, anchor_confidence=None)

    def deviation(ekf):
        rel_lin = ekf._first[: len(LANDMARKS)] - ekf._robot_prior[:2]
        rel_est = ekf.x[3:].reshape(-1, 2) - ekf.x[:2]
        return np.abs(rel_lin - rel_est).max()

    assert deviation(oc) <= deviation(fej)


@pytest.mark.slow
@pytest.mark.parametrize("jacobians", ["oc"])
def test_oc_is_consistent_over_a_monte_carlo(jacobians):
    """Regime 2 of research/notebook/2026-11-21-ekf-slam-consistency.md, 8 seeds, one lap: the OC-EKF's average NEES
    inside the 95 % band at ≥ 90 % of stamps."""
    from slamarena import datasets

    runs = []
    for seed in range(8):
        seq = datasets.load("sim:landmarks", seed=seed, laps=1, n_landmarks=30, sigma_omega=0.1, sigma_bearing=0.0349)
        _, series = nees(EKFSLAM(jacobians=jacobians).run(seq), reference_of(seq))
        runs.append((series["t"], series["nees"]))
    mc = monte_carlo(runs, dof=3)
    assert mc["in_band"] > 0.9
    assert abs(mc["mean"].mean() - 3.0) < 0.6
