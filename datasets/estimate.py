"""The result of every estimator and mapper: :class:`Estimate`.

It lives in the data layer so that ``estimators`` and ``mapping`` (one layer up, side by
side) and the experiment runner share one type.

``Estimate`` fields (K estimated poses, L landmarks)
    method          registry name of the method
    t (K,)          pose times [s], strictly increasing: one pose per stamp (a filter keeps its posterior)
    poses (K, 3)    (x, y, θ) in the world frame
    poses_3d        (K, 4, 4) ``T_world←body`` of a 3-D trajectory (camera methods), or ``None``; ``poses`` then
                    holds its top view (the method documents which plane)
    pose_cov        (K, 3, 3) world-frame covariance of (x, y, θ), or ``None``
    landmark_ids    (L,) int, landmarks (L, 2), landmark_cov (L, 2, 2) or ``None``
    step_time (K,)  wall time [s] spent producing each pose (filters: the predict+update work
                    since the previous pose), so cost curves of different methods compare
    diagnostics     dict of arrays: innovations, NIS with their dimension, association
                    decisions, rejected-measurement counts — method specific, documented by it
    meta            JSON-serialisable dict (parameters, counts, notes)
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Estimate"]


@dataclass
class Estimate:
    method: str
    t: np.ndarray
    poses: np.ndarray
    pose_cov: np.ndarray | None = None
    landmark_ids: np.ndarray | None = None
    landmarks: np.ndarray | None = None
    landmark_cov: np.ndarray | None = None
    step_time: np.ndarray | None = None
    diagnostics: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    poses_3d: np.ndarray | None = None

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float)
        self.poses = np.asarray(self.poses, dtype=float).reshape(-1, 3)
        if self.poses.shape[0] != self.t.shape[0]:
            raise ValueError(f"Estimate: {self.poses.shape[0]} poses but {self.t.shape[0]} times")
        if self.t.size > 1 and not np.all(np.diff(self.t) > 0):
            k = int(np.flatnonzero(np.diff(self.t) <= 0)[0])
            raise ValueError(
                f"Estimate ({self.method}): times must increase strictly — one pose per stamp — "
                f"but t[{k + 1}] = {self.t[k + 1]!r} follows {self.t[k]!r}"
            )
        if self.poses_3d is not None:
            self.poses_3d = np.asarray(self.poses_3d, dtype=float).reshape(-1, 4, 4)
            if self.poses_3d.shape[0] != self.t.shape[0]:
                raise ValueError(f"Estimate: {self.poses_3d.shape[0]} 3-D poses but {self.t.shape[0]} times")
        if self.pose_cov is not None:
            self.pose_cov = np.asarray(self.pose_cov, dtype=float).reshape(-1, 3, 3)
        if self.landmarks is not None:
            self.landmarks = np.asarray(self.landmarks, dtype=float).reshape(-1, 2)
            self.landmark_ids = np.asarray(self.landmark_ids, dtype=np.int64).reshape(-1)

    _ARRAYS = ("t", "poses", "pose_cov", "poses_3d", "landmark_ids", "landmarks", "landmark_cov", "step_time")

    def save(self, path: str | Path) -> None:
        """Write to ``.npz`` (arrays, diagnostics prefixed ``diag/``, meta as JSON), atomically."""
        path = Path(path)
        arrays = {k: getattr(self, k) for k in self._ARRAYS if getattr(self, k) is not None}
        arrays.update({f"diag/{k}": np.asarray(v) for k, v in self.diagnostics.items()})
        arrays["method"] = np.array(self.method)
        arrays["meta"] = np.array(json.dumps(self.meta, default=_jsonable))
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
        tmp.replace(path)

    @classmethod
    def load(cls, path: str | Path) -> Estimate:
        with np.load(path, allow_pickle=False) as data:
            kwargs = {k: data[k] for k in cls._ARRAYS if k in data.files}
            diagnostics = {k[5:]: data[k] for k in data.files if k.startswith("diag/")}
            return cls(
                method=str(data["method"]), diagnostics=diagnostics, meta=json.loads(str(data["meta"])), **kwargs
            )


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
