"""Landmark map error.

The estimated landmarks are mapped by the trajectory alignment ``A`` of the ATE (same mode,
fitted on the trajectory, so the map is judged in the frame the trajectory is judged in; if
the dataset has no ground-truth trajectory, ``A`` is fitted on the id-matched landmarks).
Matching:

* ``by: id`` — estimated landmark ``id`` ↔ true landmark ``id`` (estimators with known data
  association keep the dataset's ids);
* ``by: nearest`` — when ids are unknown: the one-to-one assignment minimising the total
  distance (``scipy.optimize.linear_sum_assignment``, i.e. nearest neighbours without
  double use), pairs farther than ``max_distance`` rejected.

``rmse = sqrt(mean ||A(m̂_i) − m_i||²)`` over matched pairs; ``missed`` = true landmarks that
were observed (ids seen in the range-bearing stream, else all) but not matched;
``spurious`` = estimated landmarks without a match.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from slamarena.datasets.estimate import Estimate
from slamarena.params import Params

from .alignment import fit_alignment
from .reference import MetricUnavailable, Reference, associate

__all__ = ["MapParams", "landmark_error", "MAP_OUTPUTS"]


class MapParams(Params):
    align: Literal["none", "se2", "sim2"] = "se2"
    by: Literal["id", "nearest"] = "id"
    max_distance: float = Field(2.0, gt=0, description="nearest-neighbour gate [m]")
    max_gap: float = Field(0.1, ge=0)


MAP_OUTPUTS = {
    "rmse": ("lower", "landmark position RMSE after alignment [m]"),
    "max": ("lower", "maximum landmark position error [m]"),
    "matched": ("higher", "matched landmarks"),
    "missed": ("lower", "observed true landmarks without a match"),
    "spurious": ("lower", "estimated landmarks without a match"),
}


def landmark_error(estimate: Estimate, ref: Reference, params: MapParams = MapParams()) -> tuple[dict, dict]:
    if estimate.landmarks is None or len(estimate.landmarks) == 0:
        raise MetricUnavailable(f"{estimate.method} estimates no landmarks")
    if ref.landmarks is None:
        raise MetricUnavailable("the dataset has no ground-truth landmarks")
    est_ids, est_xy = estimate.landmark_ids, estimate.landmarks
    gt_ids, gt_xy = ref.landmark_ids, ref.landmarks

    def by_id():
        common, ie, ig = np.intersect1d(est_ids, gt_ids, return_indices=True)
        return ie, ig

    if ref.t is not None:
        assoc = associate(ref, estimate.t, params.max_gap)
        if assoc.index.size == 0:
            raise MetricUnavailable("no estimate time has ground truth for the alignment")
        A = fit_alignment(estimate.poses[assoc.index, :2], assoc.gt[:, :2], params.align)
    else:
        ie, ig = by_id()
        if params.by != "id" or ie.size == 0:
            raise MetricUnavailable("no ground-truth trajectory and no id-matched landmarks to align on")
        A = fit_alignment(est_xy[ie], gt_xy[ig], params.align)
    aligned = A.points(est_xy)

    if params.by == "id":
        ie, ig = by_id()
    else:
        from scipy.optimize import linear_sum_assignment

        distance = np.linalg.norm(aligned[:, None, :] - gt_xy[None, :, :], axis=2)
        # pairs beyond the gate all cost more than any set of gated-in pairs together, so the
        # assignment first maximises the number of gated-in pairs, then minimises their distance
        beyond = params.max_distance * (min(distance.shape) + 1)
        ie, ig = linear_sum_assignment(np.where(distance <= params.max_distance, distance, beyond))
        keep = distance[ie, ig] <= params.max_distance
        ie, ig = ie[keep], ig[keep]
    if ie.size == 0:
        raise MetricUnavailable(f"no estimated landmark matches a true one (by {params.by})")
    err = np.linalg.norm(aligned[ie] - gt_xy[ig], axis=1)
    observed = gt_ids if ref.observed_ids is None else np.intersect1d(gt_ids, ref.observed_ids)
    out = {
        "rmse": float(np.sqrt(np.mean(err**2))),
        "max": float(err.max()),
        "matched": int(ie.size),
        "missed": int(np.setdiff1d(observed, gt_ids[ig]).size),
        "spurious": int(len(est_ids) - ie.size),
    }
    return out, {"est_index": ie, "gt_index": ig, "error": err, "aligned": aligned}
