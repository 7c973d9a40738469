"""Relation-based error (Kümmerle et al., "On measuring the accuracy of SLAM algorithms", 2009).

A relations file lists N reference relative poses ``δ*_ij`` between timestamps ``(t_i, t_j)``.
The estimate's relation is ``δ_ij = p_i⁻¹ p_j`` with ``p_i`` the estimated pose at ``t_i``
(``match: nearest`` — the estimate pose nearest in time, within ``tolerance`` seconds;
``match: interpolate`` — SE(2) interpolation between the estimate poses around ``t_i``).
The error of one relation is ``ε_ij = δ*_ij⁻¹ δ_ij`` (``between(δ*, δ)``) and::

    trans_ij = ||ε_ij.xy||,  rot_ij = |ε_ij.θ|
    reported: mean ± std of trans and rot, and the mean squared errors (the paper's ε(δ)); and the translational
    error of the local relations (stamps less than ``local_span`` apart; FR-Clinic's published rows use only
    those) and of the others (revisits, "global")

Relations whose stamps cannot be matched are dropped and counted. The relations come from
``slamarena.datasets.formats.relations`` (stamps of the original log, mapped to the
Sequence's scan times through ``meta["scan_ipc_timestamp"]`` where present), are given as arrays
``(t_i, t_j, δ*)``, or are derived from a ground-truth trajectory's revisits (:func:`revisit_relations`): the
relations of a loop's overlap, which are zero-error only for an estimate whose map is consistent where the path
meets itself — a measure of loop closure that a globally small but unclosed drift does not pass.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, field_validator

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, interpolate_poses
from slamarena.datasets.log_stamps import sequence_times
from slamarena.params import Params

from .reference import MetricUnavailable, Reference, associate

__all__ = [
    "RelationsParams",
    "relation_error",
    "relation_error_from_file",
    "revisit_relations",
    "LoopParams",
    "loop_relation_error",
    "RELATION_OUTPUTS",
    "LOOP_OUTPUTS",
]


class RelationsParams(Params):
    file: Path | None = Field(None, description="relations file (Kümmerle et al. format); default: the dataset's")
    match: Literal["nearest", "interpolate"] = "nearest"
    tolerance: float = Field(0.05, ge=0, description="seconds, for match: nearest")
    local_span: float = Field(
        600.0,
        gt=0,
        description="a relation is local when its two stamps are less than this apart [s] (the local_* outputs)",
    )

    @field_validator("file")
    @classmethod
    def _exists(cls, path):
        if path is not None and not Path(path).is_file():
            raise ValueError(f"relations file {path} does not exist")
        return path


RELATION_OUTPUTS = {
    "trans_mean": ("lower", "mean translational relation error [m]"),
    "trans_std": (None, "std of the translational relation error [m]"),
    "rot_mean": ("lower", "mean rotational relation error [rad]"),
    "rot_std": (None, "std of the rotational relation error [rad]"),
    "trans_sq_mean": ("lower", "mean squared translational error [m²]"),
    "rot_sq_mean": ("lower", "mean squared rotational error [rad²]"),
    "local_trans_mean": ("lower", "mean translational error of the local relations (stamps < local_span apart) [m]"),
    "local_trans_std": (None, "std of the translational error of the local relations [m]"),
    "global_trans_mean": ("lower", "mean translational error of the other relations (revisits) [m]"),
    "local": (None, "local relations matched to the estimate"),
    "used": ("higher", "relations matched to the estimate"),
    "dropped": ("lower", "relations whose stamps had no estimate pose"),
}


def _poses_at(estimate: Estimate, t: np.ndarray, match: str, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    et = estimate.t
    if match == "interpolate":
        ok = (t >= et[0]) & (t <= et[-1])
        poses = np.zeros((t.size, 3))
        poses[ok] = interpolate_poses(et, estimate.poses, t[ok])
        return poses, ok
    right = np.clip(np.searchsorted(et, t), 0, et.size - 1)
    left = np.clip(right - 1, 0, et.size - 1)
    nearest = np.where(np.abs(et[left] - t) <= np.abs(et[right] - t), left, right)
    return estimate.poses[nearest], np.abs(et[nearest] - t) <= tolerance


def relation_error(
    estimate: Estimate,
    t_i: np.ndarray,
    t_j: np.ndarray,
    delta_ref: np.ndarray,
    params: RelationsParams = RelationsParams(),
) -> tuple[dict, dict]:
    t_i, t_j = np.asarray(t_i, dtype=float), np.asarray(t_j, dtype=float)
    delta_ref = np.asarray(delta_ref, dtype=float).reshape(-1, 3)
    p_i, ok_i = _poses_at(estimate, t_i, params.match, params.tolerance)
    p_j, ok_j = _poses_at(estimate, t_j, params.match, params.tolerance)
    ok = ok_i & ok_j
    if not ok.any():
        raise MetricUnavailable("no relation's stamps match the estimate")
    eps = between(delta_ref[ok], between(p_i[ok], p_j[ok]))
    trans, rot = np.linalg.norm(eps[:, :2], axis=1), np.abs(eps[:, 2])
    local = np.abs(t_j[ok] - t_i[ok]) < params.local_span
    nan = float("nan")
    out = {
        "trans_mean": float(trans.mean()),
        "trans_std": float(trans.std()),
        "rot_mean": float(rot.mean()),
        "rot_std": float(rot.std()),
        "trans_sq_mean": float(np.mean(trans**2)),
        "rot_sq_mean": float(np.mean(rot**2)),
        "local_trans_mean": float(trans[local].mean()) if local.any() else nan,
        "local_trans_std": float(trans[local].std()) if local.any() else nan,
        "global_trans_mean": float(trans[~local].mean()) if (~local).any() else nan,
        "local": int(local.sum()),
        "used": int(ok.sum()),
        "dropped": int((~ok).sum()),
    }
    return out, {"t": t_i[ok], "trans_error": trans, "rot_error": rot}


def revisit_relations(
    t: np.ndarray, poses: np.ndarray, radius: float = 0.25, min_travel: float = 20.0, stride: int = 5
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Relations ``(t_i, t_j, δ*_ij)`` between the places a reference trajectory ``poses`` (N, 3) at ``t`` (N,) revisits.

    For every ``stride``-th pose i, j is the later pose nearest to it in position among those at least ``min_travel``
    metres of path after it; the pair is kept when ``||p_j.xy − p_i.xy|| ≤ radius``, and ``δ*_ij = p_i⁻¹ p_j``.
    """
    from scipy.spatial import cKDTree

    t, poses = np.asarray(t, dtype=float), np.asarray(poses, dtype=float).reshape(-1, 3)
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1))])
    starts = np.arange(0, len(poses), stride)
    pairs = []
    for i, near in zip(starts, cKDTree(poses[:, :2]).query_ball_point(poses[starts, :2], radius)):
        near = np.asarray(near, dtype=int)
        near = near[(near > i) & (travel[near] - travel[i] >= min_travel)]
        if near.size:
            pairs.append((i, near[np.argmin(np.linalg.norm(poses[near, :2] - poses[i, :2], axis=1))]))
    i, j = np.array(pairs, dtype=int).reshape(-1, 2).T
    return t[i], t[j], between(poses[i], poses[j])


class LoopParams(Params):
    """The loop metric: :func:`revisit_relations` of the ground truth at the estimate's times, scored by :func:`relation_error`."""

    radius: float = Field(0.25, gt=0, description="a revisit pairs two poses at most this far apart [m]")
    min_travel: float = Field(20.0, gt=0, description="…and at least this much path apart [m]")
    stride: int = Field(5, ge=1, description="every stride-th estimate pose starts a pair")
    max_gap: float = Field(
        0.1, ge=0, description="seconds between the estimate time and the ground-truth samples around it"
    )


LOOP_OUTPUTS = {
    "trans_mean": ("lower", "mean translational error of the loop relations (revisits of the ground truth) [m]"),
    "trans_std": (None, "std of the translational error of the loop relations [m]"),
    "rot_mean": ("lower", "mean rotational error of the loop relations [rad]"),
    "used": (None, "loop relations"),
}


def loop_relation_error(estimate: Estimate, ref: Reference, params: LoopParams = LoopParams()) -> tuple[dict, dict]:
    """Relation error on the places the ground truth revisits: small only where the estimate's map is consistent where
    its path meets itself (a closed loop), whatever the drift in between."""
    assoc = associate(ref, estimate.t, params.max_gap)
    t = estimate.t[assoc.index]
    t_i, t_j, delta = revisit_relations(t, assoc.gt, params.radius, params.min_travel, params.stride)
    if t_i.size == 0:
        raise MetricUnavailable(
            f"the ground truth revisits no place (within {params.radius} m after {params.min_travel} m of path)"
        )
    scores, series = relation_error(
        Estimate(estimate.method, t, estimate.poses[assoc.index]), t_i, t_j, delta, RelationsParams(tolerance=0.0)
    )
    return {k: scores[k] for k in LOOP_OUTPUTS}, series


def relation_error_from_file(estimate: Estimate, data, params: RelationsParams) -> tuple[dict, dict]:
    """Read the relations (``params.file`` or the dataset's ``meta['relations']``) and score them."""
    from slamarena.datasets.formats import relations as relations_format

    path = params.file or (getattr(data, "meta", {}) or {}).get("relations")
    if path is None:
        raise MetricUnavailable("no relations file for this dataset (set metrics.relations.file)")
    rel = relations_format.read(path)
    t1 = sequence_times(data, rel.t1, params.tolerance)
    t2 = sequence_times(data, rel.t2, params.tolerance)
    return relation_error(estimate, t1, t2, rel.se2, params)
