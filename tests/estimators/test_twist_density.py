"""The twist-noise convention (estimators.models.twist_increment_cov), one function for EKF-SLAM and FastSLAM: with a
stated row period T a row held for dt carries V M Vᵀ·T/dt (a white velocity error of density M T); without it, M per row."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from slamarena.estimators import models
from slamarena.estimators.ekf_slam import filter as ekf_filter
from slamarena.estimators.ekf_slam.filter import EKFSLAM
from slamarena.estimators.fastslam import filter as fastslam_filter
from slamarena.estimators.fastslam.filter import FastSLAM

M = np.diag([0.0117624, 0.174])  # MRCLAM's twist covariance per row [(m/s)², (rad/s)²]
T = 0.014367816  # the row period it is stated for (1/69.6 s)


def robot_cov(period, dt, v=0.3, omega=0.5) -> np.ndarray:
    """EKF-SLAM's robot covariance after rows (v, ω) held for dt (K,) from a certain start."""
    ekf = EKFSLAM(twist_cov=M, twist_period=period)
    ekf.predict_twists(np.full(len(dt), v), np.full(len(dt), omega), np.asarray(dt, dtype=float))
    return ekf.robot_cov.copy()


def test_without_a_period_every_row_carries_m_as_before():
    row_cov = np.random.default_rng(0).normal(size=(4, 3, 3))
    assert models.twist_increment_cov(row_cov, np.full(4, 0.3), None) is row_cov  # bit for bit


def test_rows_of_the_period_are_unchanged():
    dt = np.full(40, T)
    np.testing.assert_allclose(robot_cov(T, dt), robot_cov(None, dt), rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("period", [T, T / 2, 0.1])
def test_one_row_of_2t_is_two_rows_of_t_to_first_order(period):
    """One row of 2T and two rows of T (same v, ω) give the same composed covariance up to the lever of a heading error
    within the row: a constant ω error over one row and independent errors over two halves differ in the lateral
    variance by O((v·2T)² · σ_θ²) (σ_θ² the heading variance accrued over 2T), which is O(T⁴) against the covariance's
    O(T²) — the two cuts agree to first order in the row length. Tolerance: |ΔP| ≤ (v·2T)² σ_θ² elementwise (measured
    Δ_yy = 0.08 of it at T = 1/69.6 s). Per row (no period) the single long row has twice the heading variance."""
    v = 0.3
    one, two = robot_cov(period, [2 * period], v=v), robot_cov(period, [period, period], v=v)
    lever = (v * 2 * period) ** 2 * two[2, 2]
    assert np.all(np.abs(one - two) <= lever), (np.abs(one - two) / lever).max()
    assert abs(one[2, 2] - two[2, 2]) <= 1e-12 * two[2, 2]  # the heading: exact (ω's variance adds linearly in time)
    one_row, two_rows = robot_cov(None, [2 * period], v=v), robot_cov(None, [period, period], v=v)
    np.testing.assert_allclose(one_row[2, 2], 2 * two_rows[2, 2], rtol=1e-12)  # M per row: the cut changes the answer
    assert abs(one_row[2, 2] - two_rows[2, 2]) > lever


def test_both_filters_apply_the_one_convention():
    for module in (ekf_filter, fastslam_filter):
        source = inspect.getsource(module)
        assert "twist_increment_cov(" in source
    for cls in (EKFSLAM, FastSLAM):
        assert cls(twist_cov=M, twist_period=T).params.twist_period == T
