"""Relations derived from a reference trajectory and its scans: on a simulated two-lap drive where the answer is known,
and hand-checked on the corrected Intel log."""

from __future__ import annotations

import math

import numpy as np
import pytest
from checks import load_staged

import slamarena
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose, interpolate_poses
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.reference import MetricUnavailable
from slamarena.experiments.metrics.reference_relations import (
    ReferenceRelationsParams,
    reference_relation_error,
    reference_relations,
)


@pytest.fixture(scope="module")
def two_laps():
    seq = slamarena.load("sim:laser", world="loop", laps=2, sigma_range=0.0, seed=1)
    truth = interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, seq.scans.t)
    return seq, truth


def test_relations_of_a_two_lap_drive(two_laps):
    """Local relations span at most local_travel of path; the second lap revisits the first, so loop relations pair
    scans of lap 1 with scans of lap 2 at the same place, at least min_travel apart, seeing the same walls."""
    seq, truth = two_laps
    params = ReferenceRelationsParams()
    rel = reference_relations(seq.scans, truth, params)
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(truth[:, :2], axis=0), axis=1))])
    local, loop = ~rel.loop, rel.loop
    assert np.all(rel.j > rel.i)
    span = travel[rel.j] - travel[rel.i]
    assert np.all(span[local] <= params.local_travel + 1e-9) and np.all(span[local] > params.local_travel - 0.2)
    lap = len(truth) // 2
    assert loop.sum() > 0.5 * lap  # most scans of lap 1 find themselves again in lap 2
    assert np.all(span[loop] >= params.min_travel)
    assert np.all(np.linalg.norm(truth[rel.j[loop], :2] - truth[rel.i[loop], :2], axis=1) <= params.radius)
    assert np.mean(np.abs(rel.j[loop] - rel.i[loop] - lap) < 0.05 * lap) > 0.9  # mostly: one lap later


def test_error_is_zero_in_any_frame_and_known_for_a_jump(two_laps):
    """The reference itself, moved rigidly, scores 0; translating every pose after scan m by d (a jump) gives exactly d
    on the relations that straddle m and 0 on the others."""
    seq, truth = two_laps
    ref = reference_of(seq)
    moved = compose(np.array([3.0, -2.0, 0.7]), truth)
    scores, _ = reference_relation_error(Estimate("x", seq.scans.t, moved), seq, ref)
    assert scores["trans_mean"] < 1e-9 and scores["rot_mean"] < 1e-9 and scores["loop"] > 0

    m, d = len(truth) // 3, 0.25
    jumped = truth.copy()
    jumped[m:, :2] += [d * math.cos(1.0), d * math.sin(1.0)]
    scores, series = reference_relation_error(Estimate("x", seq.scans.t, jumped), seq, ref)
    rel = reference_relations(seq.scans, truth)
    straddle = (rel.i < m) & (rel.j >= m)
    assert np.allclose(series["trans_error"], d * straddle, atol=1e-9)
    assert np.isclose(scores["local_trans_mean"], d * straddle[~rel.loop].mean())
    assert np.isclose(scores["loop_trans_mean"], d * straddle[rel.loop].mean())


def test_relations_without_estimate_poses_are_counted_not_scored(two_laps):
    seq, truth = two_laps
    full, _ = reference_relation_error(Estimate("x", seq.scans.t, truth), seq, reference_of(seq))
    part, _ = reference_relation_error(Estimate("x", seq.scans.t[1:], truth[1:]), seq, reference_of(seq))
    rel = reference_relations(seq.scans, truth)
    at_first = int(np.sum((rel.i == 0) | (rel.j == 0)))  # scan 0 starts a local and a loop relation
    assert full["dropped"] == 0 and part["dropped"] == at_first > 0
    assert part["local"] + part["loop"] == full["local"] + full["loop"] - at_first
    with pytest.raises(MetricUnavailable, match="no relation's stamps match"):
        reference_relation_error(Estimate("x", seq.scans.t[:1] - 1.0, truth[:1]), seq, reference_of(seq))


def test_intel_corrected_by_hand():
    """Scan 0 (0.600266, −0.0320327, −0.354665) spins in place: its local relation reaches scan 12; scans 1 and 755
    (the start revisited, FLASER pose fields (0.68231, −0.100086, −0.938803) and (0.410811, −0.0233825, −2.98914),
    read with awk) are a loop relation, δ* = x_1⁻¹ x_755 by hand."""
    s = load_staged("carmen-corrected:intel")
    rel = reference_relations(s.scans, s.ground_truth.poses)
    assert (rel.i[0], rel.j[0]) == (0, 12) and not rel.loop[0]
    (x1, y1, t1), (x2, y2, t2) = (0.68231, -0.100086, -0.938803), (0.410811, -0.0233825, -2.98914)
    dx, dy = x2 - x1, y2 - y1
    by_hand = [math.cos(t1) * dx + math.sin(t1) * dy, -math.sin(t1) * dx + math.cos(t1) * dy, t2 - t1]
    k = np.flatnonzero(rel.loop & (rel.i == 1))
    assert k.size == 1 and rel.j[k[0]] == 755
    assert np.allclose(rel.delta[k[0]], by_hand, atol=1e-9)
    assert (~rel.loop).sum() > 890 and rel.loop.sum() > 200
