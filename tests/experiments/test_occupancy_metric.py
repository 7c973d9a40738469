"""The ``occupancy`` metric (experiments.metrics.occupancy): the map a trajectory implies, scored by
mapping.evaluation; the true trajectory scores above one with a heading drift."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.experiments.metrics import METRICS, CellData, evaluate, reference_of


@pytest.fixture(scope="module")
def laser():
    return datasets.load("sim:laser", world="loop", seed=0)


def _drifted(poses: np.ndarray, total: float) -> np.ndarray:
    """The trajectory rotated about its start by an angle growing linearly to ``total`` [rad] (a heading drift)."""
    angle = np.linspace(0.0, total, len(poses))
    c, s = np.cos(angle), np.sin(angle)
    d = poses[:, :2] - poses[0, :2]
    out = poses.copy()
    out[:, 0] = poses[0, 0] + c * d[:, 0] - s * d[:, 1]
    out[:, 1] = poses[0, 1] + s * d[:, 0] + c * d[:, 1]
    out[:, 2] = poses[:, 2] + angle
    return out


def _score(seq, poses) -> dict:
    cell = CellData(Estimate("x", seq.ground_truth.t, poses), seq, reference_of(seq))
    scalars, _, skipped = evaluate(cell, {"occupancy": METRICS["occupancy"].params(stride=4)})
    assert not skipped
    return scalars["occupancy"]


def test_the_true_trajectory_scores_above_a_drifted_one(laser):
    truth = _score(laser, laser.ground_truth.poses)
    drift = _score(laser, _drifted(laser.ground_truth.poses, 0.1))
    assert truth["hits"] > 0.99 and drift["hits"] < 0.95
    assert truth["wall_concentration"] > drift["wall_concentration"] + 0.05
    assert 0.0 < truth["sharpness"] <= 1.0 and 0.0 < truth["decided_fraction"] <= 1.0


def test_unavailable_without_scans():
    seq = datasets.load("sim:landmarks", n_landmarks=5, seed=0)
    cell = CellData(Estimate("x", seq.ground_truth.t, seq.ground_truth.poses), seq, reference_of(seq))
    _, _, skipped = evaluate(cell, {"occupancy": METRICS["occupancy"].params()})
    assert skipped == {"occupancy": "the dataset has no scans"}
