"""Stereo visual odometry: points triangulated from the rectified pair, PnP tracking against a keyframe map.

Model. The left camera's pose ``T_world←cam`` (4, 4) per frame, the world frame the left camera of the first frame;
scale is metric (the baseline b). A keyframe holds map points X (m, 3) in the world frame with their ORB
descriptors (m, 32).

Per keyframe (stereo points): ORB in the left and right images (:func:`.features.orb`), matched by Hamming distance
(:mod:`.matching`) among the pairs a rectified pair allows — same row within ``row_tolerance`` px, disparity
``d = u_l − u_r`` in ``[min_disparity, ∞)`` —, the disparity refined to a fraction of a pixel (``subpixel``:
:func:`.disparity.refine_disparity`, block matching along the row and a 1-D Lucas-Kanade step; an ORB keypoint is
located only to a pixel of its pyramid level), then DLT-triangulated (:func:`.triangulation.triangulate_dlt`) with
the left camera ``[I | 0]`` and the right camera ``[I | (−b, 0, 0)ᵀ]`` on the left point's row (the same as
z = fx b / d on a rectified pair) and moved to the world frame by the keyframe's pose.

Per frame (tracking): ORB in the left image, matched to the map points of the last ``map_keyframes`` keyframes;
``T_cam←world`` by :func:`.pnp.pnp_ransac` (P3P samples, ``pnp_threshold`` px, LM refinement on the inliers).
A frame becomes a keyframe when its PnP inliers fall below ``keyframe_inliers`` × the inliers of the first frame
tracked against the current keyframe, or below ``min_inliers`` × 2; then its own stereo points join the map (the
local map: the points made by the last ``map_keyframes`` keyframes).
A frame whose PnP fails (fewer than ``min_inliers`` inliers) takes the previous pose (counted in ``lost``).

Back end (``window`` ≥ 2): after each new keyframe, :func:`.window_ba.bundle_adjust` over the last ``window``
keyframes (stereo observations of the points each keyframe made, monocular observations of the map points it
tracked), the oldest held fixed; the frames tracked against a moved keyframe move with it (the reported trajectory
is the one after the adjustments). A failed adjustment leaves the estimate as it was and is recorded in ``meta``.

Every frame of the sequence must have a right image (a rectified pair). ``geometry`` picks whose matching,
triangulation and PnP run (:mod:`.backends`: ``ours`` or ``opencv``, the OpenCV-only baseline).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from slamarena.datasets.sequence import Camera
from slamarena.estimators.gtsam_smoother.graph import OptimizationError
from slamarena.params import Field, Params

from .backends import BACKENDS
from .disparity import refine_disparity
from .features import FeatureParams, orb
from .window_ba import Observation, bundle_adjust

__all__ = ["StereoVOParams", "VOResult", "stereo_points", "stereo_vo", "pose_matrix"]


class StereoVOParams(Params):
    """Stereo VO parameters (set a priori, not fitted to the scored frames)."""

    features: FeatureParams = Field(FeatureParams(), description="ORB features and their matching")
    row_tolerance: float = Field(1.0, ge=0, description="|v_l − v_r| of a stereo match on the rectified pair [px]")
    min_disparity: float = Field(2.0, gt=0, description="smallest disparity triangulated [px] (depth ≤ fx b / d)")
    pnp_threshold: float = Field(2.0, gt=0, description="PnP RANSAC inlier threshold [px]")
    min_inliers: int = Field(20, ge=4, description="PnP inliers below which a frame is lost")
    keyframe_inliers: float = Field(0.6, gt=0, lt=1, description="new keyframe below this × the first inliers")
    map_keyframes: int = Field(2, ge=1, description="the keyframes whose points form the local map")
    seed: int = Field(0, ge=0, description="RANSAC's random seed")
    geometry: Literal["ours", "opencv"] = Field("ours", description="whose matching, triangulation and PnP")
    window: int = Field(0, ge=0, description="keyframes of the windowed bundle adjustment (0: none)")
    subpixel: bool = Field(True, description="refine each stereo match's disparity to a fraction of a pixel")


@dataclass
class VOResult:
    """frames (K,) the frame indices, t (K,) [s], poses (K, 4, 4) ``T_world←cam``, inliers (K,) PnP inliers
    (−1 where no PnP ran: the first frame, monocular keyframe 1), keyframes (list of frame indices), cpu_time (K,)
    [s] per frame, lost (frames whose PnP failed), meta (parameters; back-end runs and failures)."""

    frames: np.ndarray
    t: np.ndarray
    poses: np.ndarray
    inliers: np.ndarray
    keyframes: list[int]
    cpu_time: np.ndarray
    lost: int = 0
    meta: dict = field(default_factory=dict)


def pose_matrix(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``T_world←cam`` (4, 4) of the PnP pose ``T_cam←world = (R, t)``."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R.T, -R.T @ t
    return T


def stereo_points(
    camera: Camera, k: int, params: StereoVOParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frame k's stereo points: left pixels (n, 2), right columns u_R (n,), camera-frame points (n, 3), left
    descriptors (n, 32)."""
    backend = BACKENDS[params.geometry]
    left, right = camera.image(k), camera.image(k, "right")
    ul, dl = orb(left, params.features.n_features)
    ur, dr = orb(right, params.features.n_features)
    disparity = ul[:, None, 0] - ur[None, :, 0]
    allowed = (np.abs(ul[:, None, 1] - ur[None, :, 1]) <= params.row_tolerance) & (disparity >= params.min_disparity)
    i, j = backend.match(dl, dr, params.features.ratio, params.features.max_distance, allowed)
    ul, dl, u_right = ul[i], dl[i], ur[j, 0]
    if params.subpixel:
        u_right, refined = refine_disparity(left, right, ul, u_right)
        refined &= ul[:, 0] - np.nan_to_num(u_right) >= params.min_disparity
        ul, dl, u_right = ul[refined], dl[refined], u_right[refined]
    K, b = camera.K, camera.baseline
    x_left = (ul - K[:2, 2]) / np.diag(K)[:2]
    x_right = (np.column_stack([u_right, ul[:, 1]]) - K[:2, 2]) / np.diag(K)[:2]  # rectified: the left row
    X = backend.triangulate(x_left, x_right, (np.eye(3), np.zeros(3)), (np.eye(3), np.array([-b, 0.0, 0.0])))
    good = np.isfinite(X).all(axis=1) & (X[:, 2] > 0)
    return ul[good], u_right[good], X[good], dl[good]


def stereo_vo(camera: Camera, params: StereoVOParams | None = None) -> VOResult:
    """Run stereo VO over every frame of ``camera`` (see the module docstring)."""
    params = StereoVOParams.of(params)
    if camera.right is None or not camera.stereo.all():
        raise ValueError(f"stereo VO needs a right image for every frame; {int((~camera.stereo).sum())} lack one")
    backend = BACKENDS[params.geometry]
    n = len(camera)
    poses = np.tile(np.eye(4), (n, 1, 1))
    reference = np.zeros(n, np.int64)  # the keyframe each frame was tracked against
    inliers = np.full(n, -1, np.int64)
    cpu = np.zeros(n)
    keyframes: list[int] = []
    points = np.zeros((0, 3))  # every map point (world), its descriptor, and the keyframe that made it
    descriptors = np.zeros((0, 32), np.uint8)
    origin = np.zeros(0, np.int64)
    observations: list[Observation] = []
    first_inliers, lost, ba_runs, ba_failures = None, 0, 0, []

    def add_keyframe(k: int, seen: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Frame k becomes a keyframe: its tracked map points (ids, pixels) and its new stereo points."""
        nonlocal first_inliers, points, descriptors, origin
        ul, ur, Xc, d = stereo_points(camera, k, params)
        ids = len(points) + np.arange(len(Xc))
        points = np.vstack([points, Xc @ poses[k, :3, :3].T + poses[k, :3, 3]])
        descriptors = np.vstack([descriptors, d])
        origin = np.concatenate([origin, np.full(len(Xc), k)])
        observations.extend(Observation(k, int(p), *u, r) for p, u, r in zip(ids, ul, ur))
        if seen is not None:
            observations.extend(Observation(k, int(p), *u) for p, u in zip(*seen))
        keyframes.append(k)
        first_inliers = None
        if params.window >= 2 and len(keyframes) >= 2:
            adjust()

    def adjust() -> None:
        nonlocal ba_runs, points
        window = keyframes[-params.window :]
        try:
            new_poses, new_points = bundle_adjust(
                camera.K, camera.baseline, {k: poses[k] for k in window}, points, observations, (window[0],)
            )
        except (OptimizationError, RuntimeError) as failure:
            ba_failures.append(f"window {window}: {failure}"[:200])
            return
        ba_runs += 1
        for k in window:  # frames tracked against a moved keyframe move with it
            move = new_poses[k] @ np.linalg.inv(poses[k])
            later = np.flatnonzero((reference == k) & (np.arange(n) > k) & (np.arange(n) <= keyframes[-1]))
            poses[later] = move @ poses[later]
            poses[k] = new_poses[k]
        for p, X in new_points.items():
            points[p] = X

    for k in range(n):
        start = time.process_time()
        if k == 0:
            add_keyframe(0, None)
            cpu[k] = time.process_time() - start
            continue
        u, d = orb(camera.image(k), params.features.n_features)
        local = np.flatnonzero(np.isin(origin, keyframes[-params.map_keyframes :]))
        i, j = backend.match(d, descriptors[local], params.features.ratio, params.features.max_distance)
        result = backend.pnp(camera.K, points[local[j]], u[i], params.pnp_threshold, params.seed + k)
        count = 0 if result is None else int(result.inliers.sum())
        inliers[k] = count
        reference[k] = keyframes[-1]
        if result is None or count < params.min_inliers:
            poses[k] = poses[k - 1]
            lost += 1
            add_keyframe(k, None)
        else:
            poses[k] = pose_matrix(result.R, result.t)
            first_inliers = count if first_inliers is None else first_inliers
            if count < params.keyframe_inliers * first_inliers or count < 2 * params.min_inliers:
                add_keyframe(k, (local[j[result.inliers]], u[i[result.inliers]]))
        cpu[k] = time.process_time() - start
    return VOResult(
        frames=np.arange(n),
        t=camera.t.copy(),
        poses=poses,
        inliers=inliers,
        keyframes=keyframes,
        cpu_time=cpu,
        lost=lost,
        meta={"params": params.model_dump(), "ba_runs": ba_runs, "ba_failures": ba_failures},
    )
