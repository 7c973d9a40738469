"""Trajectory accuracy: absolute trajectory error (ATE) and relative pose error (RPE).

ATE (Sturm et al. 2012, in SE(2)). With the reference ``q_k`` at the estimate times (see
:mod:`.reference`) and the estimate ``p_k`` aligned by ``A`` (:mod:`.alignment`, fitted on the
matched positions)::

    e_k = ||A(p_k).xy − q_k.xy||         position error [m]
    η_k = wrap(A(p_k).θ − q_k.θ)         heading error [rad]
    ATE_rmse = sqrt(mean e_k²), mean, median, max of e_k;  heading_rmse = sqrt(mean η_k²), heading_max = max |η_k|

RPE over a delta (pairs (i, j) chosen on the reference, as evo's ``pairs_from_reference``)::

    E_ij = (q_i⁻¹ q_j)⁻¹ (p_i⁻¹ p_j)     (SE(2): between(between(q_i, q_j), between(p_i, p_j)))
    trans_ij = ||E_ij.xy||,  rot_ij = |E_ij.θ|

Deltas: ``frames`` (j = i + Δ), ``s`` (the j whose time is nearest to t_i + Δ) or ``m`` (the j
whose distance travelled along the reference from i is nearest to Δ); with ``all_pairs`` every
i starts a pair, otherwise pairs are consecutive (evo's convention: for metres a new pair starts
when the path since the last one reaches Δ). Pairs farther than ``rel_tol · Δ`` from Δ are
dropped (seconds and metres). RPE needs no alignment (it is invariant to a rigid one).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between
from slamarena.params import Params

from .alignment import fit_alignment
from .reference import MetricUnavailable, Reference, associate

__all__ = ["ATEParams", "RPEParams", "ate", "rpe", "rpe_pairs", "ATE_OUTPUTS", "RPE_OUTPUTS"]


class ATEParams(Params):
    align: Literal["none", "se2", "sim2"] = "se2"
    max_gap: float = Field(
        0.1, ge=0, description="seconds between the estimate time and the ground-truth samples around it"
    )


class RPEParams(Params):
    delta: float = Field(1.0, gt=0)
    unit: Literal["frames", "s", "m"] = "s"
    all_pairs: bool = True
    rel_tol: float = Field(0.1, ge=0)
    max_gap: float = Field(0.1, ge=0)


#: output name → (better: "lower" | "higher", description)
ATE_OUTPUTS = {
    "rmse": ("lower", "position RMSE after alignment [m]"),
    "mean": ("lower", "mean position error [m]"),
    "median": ("lower", "median position error [m]"),
    "max": ("lower", "maximum position error [m]"),
    "heading_rmse": ("lower", "heading RMSE [rad]"),
    "heading_max": ("lower", "maximum absolute heading error [rad]"),
    "matched": ("higher", "estimates with ground truth"),
    "unmatched": ("lower", "estimates without ground truth within max_gap"),
    "scale": (None, "Sim(2) scale of the alignment (1 otherwise)"),
}
RPE_OUTPUTS = {
    "trans_rmse": ("lower", "translational RPE RMSE [m]"),
    "trans_mean": ("lower", "mean translational RPE [m]"),
    "trans_median": ("lower", "median translational RPE [m]"),
    "trans_max": ("lower", "maximum translational RPE [m]"),
    "rot_rmse": ("lower", "rotational RPE RMSE [rad]"),
    "rot_mean": ("lower", "mean rotational RPE [rad]"),
    "rot_max": ("lower", "maximum rotational RPE [rad]"),
    "pairs": (None, "number of pose pairs"),
}


def _stats(e: np.ndarray) -> dict:
    return {
        "rmse": float(np.sqrt(np.mean(e**2))),
        "mean": float(np.mean(e)),
        "median": float(np.median(e)),
        "max": float(np.max(e)),
    }


def ate(estimate: Estimate, ref: Reference, params: ATEParams = ATEParams()) -> tuple[dict, dict]:
    """ATE statistics and the per-step series (t, position error, heading error, aligned poses)."""
    assoc = associate(ref, estimate.t, params.max_gap)
    if assoc.index.size == 0:
        raise MetricUnavailable(f"no estimate time has ground truth within max_gap={params.max_gap} s")
    p = estimate.poses[assoc.index]
    A = fit_alignment(p[:, :2], assoc.gt[:, :2], params.align)
    aligned = A.poses(p)
    e = np.linalg.norm(aligned[:, :2] - assoc.gt[:, :2], axis=1)
    eta = np.abs(between(assoc.gt, aligned)[:, 2])
    out = _stats(e)
    out.update(
        heading_rmse=float(np.sqrt(np.mean(eta**2))),
        heading_max=float(eta.max()),
        matched=int(assoc.index.size),
        unmatched=assoc.unmatched,
        scale=A.scale,
    )
    series = {
        "t": estimate.t[assoc.index],
        "position_error": e,
        "heading_error": eta,
        "aligned_poses": aligned,
        "gt_poses": assoc.gt,
    }
    return out, {**series, "alignment": A}


def rpe_pairs(
    t: np.ndarray, xy: np.ndarray, delta: float, unit: str, all_pairs: bool = True, rel_tol: float = 0.1
) -> np.ndarray:
    """Index pairs (P, 2) at a separation ``delta`` in ``unit`` (see the module docstring)."""
    n = len(t)
    if unit == "frames":
        d = int(round(delta))
        if d != delta or d < 1:
            raise ValueError(f"a delta in frames must be a positive integer, got {delta}")
        i = np.arange(0, n - d) if all_pairs else np.arange(0, n, d)[:-1]
        i = i[i + d < n]
        return np.column_stack([i, i + d])
    if unit == "s":
        axis = np.asarray(t, dtype=float)
    elif unit == "m":
        axis = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    else:
        raise ValueError(f"RPE unit must be frames, s or m, got {unit!r}")
    if all_pairs:
        i = np.arange(n - 1)
        # nearest j > i to axis_i + delta: compare the two candidates around the target
        hi = np.clip(np.searchsorted(axis, axis[i] + delta), i + 1, n - 1)
        # the first index of a run of equal values (standing still), as an argmin would pick
        lo = np.maximum(np.searchsorted(axis, axis[np.maximum(hi - 1, i + 1)], side="left"), i + 1)
        j = np.where(np.abs(axis[lo] - axis[i] - delta) <= np.abs(axis[hi] - axis[i] - delta), lo, hi)
        keep = np.abs(axis[j] - axis[i] - delta) <= rel_tol * delta
        return np.column_stack([i[keep], j[keep]])
    ids = [0]
    for k in range(1, n):  # consecutive pairs: a new pair starts once the advance reaches delta
        if axis[k] - axis[ids[-1]] >= delta:
            ids.append(k)
    ids = np.asarray(ids)
    return np.column_stack([ids[:-1], ids[1:]])


def rpe(estimate: Estimate, ref: Reference, params: RPEParams = RPEParams()) -> tuple[dict, dict]:
    """RPE statistics over the pairs at ``params.delta`` and the per-pair series."""
    assoc = associate(ref, estimate.t, params.max_gap)
    if assoc.index.size < 2:
        raise MetricUnavailable("fewer than two estimates have ground truth")
    p, q, t = estimate.poses[assoc.index], assoc.gt, estimate.t[assoc.index]
    pairs = rpe_pairs(t, q[:, :2], params.delta, params.unit, params.all_pairs, params.rel_tol)
    if len(pairs) == 0:
        raise MetricUnavailable(f"no pose pair at delta {params.delta} {params.unit}")
    i, j = pairs[:, 0], pairs[:, 1]
    E = between(between(q[i], q[j]), between(p[i], p[j]))
    trans = np.linalg.norm(E[:, :2], axis=1)
    rot = np.abs(E[:, 2])
    ts, rs = _stats(trans), _stats(rot)
    out = {f"trans_{k}": v for k, v in ts.items()}
    out.update(rot_rmse=rs["rmse"], rot_mean=rs["mean"], rot_max=rs["max"], pairs=int(len(pairs)))
    return out, {"t": t[i], "trans_error": trans, "rot_error": rot}
