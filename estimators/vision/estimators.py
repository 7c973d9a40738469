"""The VO pipelines behind the estimator protocol (``run(sequence) -> Estimate``): ``stereo_vo`` and ``mono_vo``.

The estimate of a camera method is 3-D: ``Estimate.poses_3d`` (K, 4, 4) holds ``T_world←cam`` of every frame, the
world frame the first frame's (left) camera (x right, y down, z forward). ``Estimate.poses`` (K, 3) is its top view
in the robot convention (x forward, y left, θ counter-clockwise seen from above)::

    (x, y) = (z_w, −x_w),   θ = atan2(−R₀₂, R₂₂)   (R = rotation of T_world←cam; its third column the optical axis)

``step_time`` is the CPU time [s] spent on each frame (one process; :attr:`VOResult.cpu_time`), so the ``cost``
metric's ``step_median`` is the time per frame. ``diagnostics``: ``inliers`` (K,) PnP inliers per frame (−1 where
no PnP ran), ``keyframes`` (the keyframe frame indices), ``lost`` (frames whose PnP failed). ``meta`` records the
parameters, whether the scale is metric, and the back end's runs and failures.
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sequence import Sequence

from .mono_vo import MonoVOParams, mono_vo
from .stereo_vo import StereoVOParams, VOResult, stereo_vo

__all__ = ["StereoVO", "MonoVO", "top_view"]


def top_view(poses: np.ndarray) -> np.ndarray:
    """(K, 3) planar poses (x, y, θ) of camera poses ``T_world←cam`` (K, 4, 4) seen from above (module docstring)."""
    R, p = poses[:, :3, :3], poses[:, :3, 3]
    return np.column_stack([p[:, 2], -p[:, 0], wrap_angle(np.arctan2(-R[:, 0, 2], R[:, 2, 2]))])


def _estimate(method: str, result: VOResult, scale: str) -> Estimate:
    return Estimate(
        method=method,
        t=result.t,
        poses=top_view(result.poses),
        poses_3d=result.poses,
        step_time=result.cpu_time,
        diagnostics={
            "inliers": result.inliers,
            "keyframes": np.asarray(result.keyframes, np.int64),
            "lost": np.array(result.lost),
        },
        meta={**result.meta, "scale": scale, "keyframes": len(result.keyframes), "lost": result.lost},
    )


def _camera(sequence: Sequence, method: str):
    if sequence.camera is None or not len(sequence.camera):
        raise ValueError(f"{method} needs a camera stream; sequence {sequence.name!r} has none")
    return sequence.camera


class StereoVO:
    """Stereo VO (:mod:`.stereo_vo`; ``window`` ≥ 2 adds the windowed bundle adjustment). Metric scale."""

    Params = StereoVOParams

    def __init__(self, params: StereoVOParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def run(self, sequence: Sequence) -> Estimate:
        return _estimate("stereo_vo", stereo_vo(_camera(sequence, "stereo_vo"), self.params), "metric")


class MonoVO:
    """Monocular VO (:mod:`.mono_vo`). The scale is unobservable: evaluate after a Sim(3) alignment."""

    Params = MonoVOParams

    def __init__(self, params: MonoVOParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def run(self, sequence: Sequence) -> Estimate:
        return _estimate("mono_vo", mono_vo(_camera(sequence, "mono_vo"), self.params), "unobservable")
