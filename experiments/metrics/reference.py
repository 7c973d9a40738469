"""Ground truth of a loaded dataset and its association with an estimate's times.

The reference at an estimate time ``t`` is the SE(2) (constant-twist) interpolation
(:func:`slamarena.datasets.geometry.interpolate_poses`) between the ground-truth samples around ``t``.
It is used when ``t`` coincides with a sample (within 1 µs) or both samples around it lie
within ``max_gap`` seconds of ``t``; other estimates (outside the ground-truth span, or in a
gap of the ground truth) are excluded and counted (``unmatched``).

Pose graphs carry ground truth per node (``PoseGraph.true_poses``); their estimates are
indexed by node id in ``Estimate.t``, so node ids act as times (``max_gap`` 0: exact match).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slamarena.datasets.geometry import interpolate_poses

__all__ = ["Reference", "reference_of", "associate", "Association", "MetricUnavailable"]

_EXACT = 1e-6


class MetricUnavailable(Exception):
    """A metric does not apply to this cell (no ground truth, no covariance, …); the reason is recorded."""


@dataclass(frozen=True)
class Reference:
    t: np.ndarray | None
    poses: np.ndarray | None
    landmark_ids: np.ndarray | None
    landmarks: np.ndarray | None
    observed_ids: np.ndarray | None


def reference_of(data) -> Reference:
    """The ground truth a Sequence or PoseGraph carries (fields ``None`` where absent)."""
    gt = getattr(data, "ground_truth", None)
    if gt is not None and len(gt):
        t, poses = gt.t, gt.poses
    elif getattr(data, "true_poses", None) is not None:
        t, poses = data.node_ids.astype(float), data.true_poses
    else:
        t = poses = None
    lm = getattr(data, "landmarks", None) or getattr(data, "true_landmarks", None)
    rb = getattr(data, "range_bearing", None)
    observed = None
    if rb is not None and np.any(rb.landmark_id >= 0):
        observed = np.unique(rb.landmark_id[rb.landmark_id >= 0])
    elif getattr(data, "landmark_id", None) is not None:
        observed = np.unique(data.landmark_id)
    return Reference(t, poses, None if lm is None else lm.ids, None if lm is None else lm.xy, observed)


@dataclass(frozen=True)
class Association:
    index: np.ndarray  # (M,) indices into the estimate that have a reference
    gt: np.ndarray  # (M, 3) reference poses at those estimate times
    unmatched: int


def associate(ref: Reference, t: np.ndarray, max_gap: float) -> Association:
    """Reference poses at the estimate times ``t`` (see the module docstring for the rule)."""
    if ref.t is None:
        raise MetricUnavailable("the dataset has no ground-truth trajectory")
    t = np.asarray(t, dtype=float)
    gt_t = ref.t
    inside = (t >= gt_t[0] - _EXACT) & (t <= gt_t[-1] + _EXACT)
    tq = np.clip(t, gt_t[0], gt_t[-1])
    right = np.clip(np.searchsorted(gt_t, tq, side="left"), 0, len(gt_t) - 1)
    left = np.clip(right - 1, 0, len(gt_t) - 1)
    exact = (np.abs(gt_t[right] - tq) <= _EXACT) | (np.abs(gt_t[left] - tq) <= _EXACT)
    bracketed = (tq - gt_t[left] <= max_gap) & (gt_t[right] - tq <= max_gap)
    ok = inside & (exact | bracketed)
    index = np.flatnonzero(ok)
    if len(gt_t) == 1:
        gt = np.repeat(ref.poses[:1], index.size, axis=0)
    else:
        gt = interpolate_poses(gt_t, ref.poses, tq[index])
    return Association(index, gt, int(t.size - index.size))
