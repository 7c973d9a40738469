"""Relations derived from a reference trajectory and its scans (a SLAM-corrected log), scored like Kümmerle's.

A corrected log carries a reference pose ``x_k`` (3,) per kept scan ``k`` (K scans, stamps ``t_k``): a SLAM system's
result, not ground truth. From it, two sets of relations ``(i, j, δ*_ij = x_i⁻¹ x_j)``, with ``s_k`` the reference
path length up to scan k:

- **local**: for every ``stride``-th scan i (but those in the last ``local_travel`` metres), j = the last scan with
  ``0 < s_j − s_i ≤ local_travel`` (the scan about ``local_travel`` metres of path further).
  They measure the front end: motion over a metre or two.
- **loop**: for every ``stride``-th scan i, the later scans j with ``s_j − s_i ≥ min_travel`` and
  ``‖x_j.xy − x_i.xy‖ ≤ radius``; of these the nearest in position, kept when the two scans **see the same place**:
  at least ``min_overlap`` of scan i's usable end points (placed at ``x_i``) lie within ``overlap_distance`` of an end
  point of scan j (placed at ``x_j``). They measure global consistency where the path meets itself.

The error of an estimate on a relation is Kümmerle's, ``ε_ij = δ*_ij⁻¹ (p_i⁻¹ p_j)``
(:func:`~slamarena.experiments.metrics.relations.relation_error`); reported as mean ± std over all relations and the
mean of each set; relations whose scans have no estimate pose are not scored and are counted (``dropped``).

What they can show: a front end that drifts over metres (local), a map that is torn or stretched where the reference
closes a loop (loop), independently of the frame the estimate is in. What they cannot: an error smaller than the
reference's own (a few centimetres for a GMapping-style RBPF: a method better than the reference scores as large an
error as the reference has); an error in places the path never meets again (no loop relation there); and where the
reference itself is wrong, they reward agreeing with it. The overlap test only accepts pairs the reference aligns; a
revisit the reference failed to close is not a loop relation.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field
from scipy.spatial import cKDTree

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, interpolate_poses
from slamarena.mapping.evaluation import _end_points
from slamarena.params import Params

from .reference import MetricUnavailable, Reference
from .relations import RelationsParams, _poses_at, relation_error, revisit_relations

__all__ = [
    "ReferenceRelationsParams",
    "ReferenceRelations",
    "reference_relations",
    "reference_relation_error",
    "REFERENCE_RELATION_OUTPUTS",
]


class ReferenceRelationsParams(Params):
    local_travel: float = Field(2.0, gt=0, description="a local relation spans about this much reference path [m]")
    stride: int = Field(1, ge=1, description="every stride-th scan starts a local and a loop relation")
    min_travel: float = Field(10.0, gt=0, description="a loop relation spans at least this much reference path [m]")
    radius: float = Field(2.0, gt=0, description="… between scans at most this far apart [m]")
    overlap_distance: float = Field(0.2, gt=0, description="an end point is seen by both scans within this [m]")
    min_overlap: float = Field(0.3, gt=0, le=1, description="fraction of end points both scans see, at least")


REFERENCE_RELATION_OUTPUTS = {
    "trans_mean": ("lower", "mean translational error of the local and loop relations of the reference [m]"),
    "trans_std": (None, "std of that error [m]"),
    "rot_mean": ("lower", "mean rotational error of the local and loop relations [rad]"),
    "local_trans_mean": ("lower", "mean translational error of the local relations [m]"),
    "loop_trans_mean": ("lower", "mean translational error of the loop relations (scans seeing the same place) [m]"),
    "local": (None, "local relations scored"),
    "loop": (None, "loop relations scored"),
    "dropped": ("lower", "reference relations whose scans had no estimate pose (not scored)"),
}


class ReferenceRelations:
    """The relations of one reference: scan indices ``i``, ``j`` (n,), ``delta`` (n, 3) and ``loop`` (n,) bool."""

    def __init__(self, i: np.ndarray, j: np.ndarray, delta: np.ndarray, loop: np.ndarray):
        self.i, self.j, self.delta, self.loop = i, j, delta, loop


def _overlap(scans, poses: np.ndarray, i: int, j: int, distance: float) -> float:
    """Fraction of scan i's usable end points (at poses[i]) within ``distance`` of one of scan j's (at poses[j])."""
    ok_i, pts_i = _end_points(scans, poses[i], i, scans.max_range)
    ok_j, pts_j = _end_points(scans, poses[j], j, scans.max_range)
    if not ok_i.any() or not ok_j.any():
        return 0.0
    d, _ = cKDTree(pts_j[ok_j]).query(pts_i[ok_i], distance_upper_bound=distance)
    return float(np.mean(np.isfinite(d)))


def reference_relations(
    scans, poses: np.ndarray, params: ReferenceRelationsParams = ReferenceRelationsParams()
) -> ReferenceRelations:
    """The local and loop relations of the reference ``poses`` (K, 3) of ``scans`` (module docstring)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1))])
    starts = np.arange(0, len(poses), params.stride)
    last = np.searchsorted(travel, travel[starts] + params.local_travel, side="right") - 1
    moved = (last > starts) & (travel[starts] + params.local_travel <= travel[-1])  # not in the last metres
    li, lj = starts[moved], last[moved]
    index = np.arange(len(poses), dtype=float)  # revisit_relations on scan indices as its "times"
    ci, cj, _ = revisit_relations(index, poses, params.radius, params.min_travel, params.stride)
    ci, cj = ci.astype(int), cj.astype(int)
    seen = np.array(
        [_overlap(scans, poses, a, b, params.overlap_distance) >= params.min_overlap for a, b in zip(ci, cj)], bool
    )
    i = np.concatenate([li, ci[seen]])
    j = np.concatenate([lj, cj[seen]])
    loop = np.concatenate([np.zeros(li.size, bool), np.ones(int(seen.sum()), bool)])
    return ReferenceRelations(i, j, between(poses[i], poses[j]), loop)


def reference_relation_error(
    estimate: Estimate, data, ref: Reference, params: ReferenceRelationsParams = ReferenceRelationsParams()
) -> tuple[dict, dict]:
    """The estimate's error on the reference relations of ``data``'s scans, the reference ``ref`` interpolated at the
    scan stamps (a corrected log's ground truth is one pose per scan: taken as it is)."""
    scans = getattr(data, "scans", None)
    if scans is None or ref.t is None or scans.t[0] < ref.t[0] or scans.t[-1] > ref.t[-1]:
        raise MetricUnavailable("reference relations need scans and a reference over the span of every scan")
    rel = reference_relations(scans, interpolate_poses(ref.t, ref.poses, scans.t), params)
    if rel.i.size == 0:
        raise MetricUnavailable("the reference has no relation (no motion)")
    t = scans.t
    match = RelationsParams(match="nearest", tolerance=1e-6)
    scores, series = relation_error(estimate, t[rel.i], t[rel.j], rel.delta, match)
    _, ok_i = _poses_at(estimate, t[rel.i], match.match, match.tolerance)
    _, ok_j = _poses_at(estimate, t[rel.j], match.match, match.tolerance)
    loop = rel.loop[ok_i & ok_j]  # the relations scored, as relation_error kept them
    trans = series["trans_error"]
    nan = float("nan")
    out = {
        "trans_mean": scores["trans_mean"],
        "trans_std": scores["trans_std"],
        "rot_mean": scores["rot_mean"],
        "local_trans_mean": float(trans[~loop].mean()) if (~loop).any() else nan,
        "loop_trans_mean": float(trans[loop].mean()) if loop.any() else nan,
        "local": int((~loop).sum()),
        "loop": int(loop.sum()),
        "dropped": scores["dropped"],
    }
    return out, {**series, "loop": loop}
