"""Stereo visual odometry: points triangulated from the rectified pair, PnP tracking against a keyframe map.

Model. The left camera's pose ``T_world←cam`` (4, 4) per frame, the world frame the left camera of the first frame;
scale is metric (the baseline b). A keyframe holds map points X (m, 3) in the world frame with their ORB
descriptors (m, 32).

Per keyframe (stereo points): ORB in the left and right images (:func:`.features.orb`), matched by Hamming distance
(:mod:`.matching`) among the pairs a rectified pair allows — same row within ``row_tolerance`` px, disparity
``d = u_l − u_r`` in ``[min_disparity, ∞)`` — then DLT-triangulated (:func:`.triangulation.triangulate_dlt`) with
the left camera ``[I | 0]`` and the right camera ``[I | (−b, 0, 0)ᵀ]`` (the same as z = fx b / d on a rectified
pair) and moved to the world frame by the keyframe's pose.

Per frame (tracking): ORB in the left image, matched to the map points of the last ``map_keyframes`` keyframes;
``T_cam←world`` by :func:`.pnp.pnp_ransac` (P3P samples, ``pnp_threshold`` px, LM refinement on the inliers).
A frame becomes a keyframe when its PnP inliers fall below ``keyframe_inliers`` × the inliers of the first frame
tracked against the current keyframe, or below ``min_inliers`` × 2; then its own stereo points join the map.
A frame whose PnP fails (fewer than ``min_inliers`` inliers) takes the previous pose (counted in ``lost``).

Every frame of the sequence must have a right image (a rectified pair). ``geometry`` picks whose matching,
triangulation and PnP run (:mod:`.backends`: ``ours`` or ``opencv``, the OpenCV-only baseline).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from slamarena.datasets.sequence import Camera
from slamarena.params import Field, Params

from .backends import BACKENDS
from .features import orb

__all__ = ["StereoVOParams", "VOResult", "stereo_points", "stereo_vo", "pose_matrix"]


class StereoVOParams(Params):
    """Stereo VO parameters (set a priori, not fitted to the scored frames)."""

    n_features: int = Field(2000, ge=50, description="ORB features per image")
    ratio: float = Field(0.8, gt=0, le=1, description="Lowe's ratio test")
    max_distance: int = Field(64, ge=0, le=256, description="largest Hamming distance of a match [bits]")
    row_tolerance: float = Field(1.0, ge=0, description="|v_l − v_r| of a stereo match on the rectified pair [px]")
    min_disparity: float = Field(2.0, gt=0, description="smallest disparity triangulated [px] (depth ≤ fx b / d)")
    pnp_threshold: float = Field(2.0, gt=0, description="PnP RANSAC inlier threshold [px]")
    min_inliers: int = Field(20, ge=4, description="PnP inliers below which a frame is lost")
    keyframe_inliers: float = Field(0.6, gt=0, lt=1, description="new keyframe below this × the first inliers")
    map_keyframes: int = Field(2, ge=1, description="the keyframes whose points form the local map")
    seed: int = Field(0, ge=0, description="RANSAC's random seed")
    geometry: Literal["ours", "opencv"] = Field("ours", description="whose matching, triangulation and PnP")


@dataclass
class VOResult:
    """frames (K,) the frame indices, t (K,) [s], poses (K, 4, 4) ``T_world←cam``, inliers (K,) PnP inliers
    (−1 at keyframes' own start), keyframes (list of frame indices), cpu_time (K,) [s] per frame, lost count, and
    the keyframes' map points/descriptors/observations for a back end."""

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


def stereo_points(camera: Camera, k: int, params: StereoVOParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frame k's stereo points: left pixels (n, 2), camera-frame points (n, 3), left descriptors (n, 32)."""
    backend = BACKENDS[params.geometry]
    ul, dl = orb(camera.image(k), params.n_features)
    ur, dr = orb(camera.image(k, "right"), params.n_features)
    disparity = ul[:, None, 0] - ur[None, :, 0]
    allowed = (np.abs(ul[:, None, 1] - ur[None, :, 1]) <= params.row_tolerance) & (disparity >= params.min_disparity)
    i, j = backend.match(dl, dr, params.ratio, params.max_distance, allowed)
    K, b = camera.K, camera.baseline
    x_left = (ul[i] - K[:2, 2]) / np.diag(K)[:2]
    x_right = (ur[j] - K[:2, 2]) / np.diag(K)[:2]
    X = backend.triangulate(x_left, x_right, (np.eye(3), np.zeros(3)), (np.eye(3), np.array([-b, 0.0, 0.0])))
    good = np.isfinite(X).all(axis=1) & (X[:, 2] > 0)
    return ul[i][good], X[good], dl[i][good]


def stereo_vo(camera: Camera, params: StereoVOParams | None = None) -> VOResult:
    """Run stereo VO over every frame of ``camera`` (see the module docstring)."""
    params = StereoVOParams.of(params)
    if camera.right is None or not camera.stereo.all():
        raise ValueError(f"stereo VO needs a right image for every frame; {int((~camera.stereo).sum())} lack one")
    backend = BACKENDS[params.geometry]
    n = len(camera)
    poses = np.tile(np.eye(4), (n, 1, 1))
    inliers = np.full(n, -1, np.int64)
    cpu = np.zeros(n)
    keyframes: list[int] = []
    maps: list[tuple[np.ndarray, np.ndarray]] = []  # per keyframe: world points (m, 3), descriptors (m, 32)
    first_inliers, lost = None, 0

    def add_keyframe(k: int) -> None:
        nonlocal first_inliers
        _, Xc, d = stereo_points(camera, k, params)
        Xw = Xc @ poses[k, :3, :3].T + poses[k, :3, 3]
        keyframes.append(k)
        maps.append((Xw, d))
        del maps[: -params.map_keyframes]
        first_inliers = None

    for k in range(n):
        start = time.process_time()
        if k == 0:
            add_keyframe(0)
            cpu[k] = time.process_time() - start
            continue
        u, d = orb(camera.image(k), params.n_features)
        X_map = np.concatenate([m[0] for m in maps])
        d_map = np.concatenate([m[1] for m in maps])
        i, j = backend.match(d, d_map, params.ratio, params.max_distance)
        result = backend.pnp(camera.K, X_map[j], u[i], params.pnp_threshold, params.seed + k)
        count = 0 if result is None else int(result.inliers.sum())
        if result is None or count < params.min_inliers:
            poses[k] = poses[k - 1]
            lost += 1
            inliers[k] = count
            add_keyframe(k)
        else:
            poses[k] = pose_matrix(result.R, result.t)
            inliers[k] = count
            if first_inliers is None:
                first_inliers = count
            if count < params.keyframe_inliers * first_inliers or count < 2 * params.min_inliers:
                add_keyframe(k)
        cpu[k] = time.process_time() - start
    return VOResult(
        frames=np.arange(n),
        t=camera.t.copy(),
        poses=poses,
        inliers=inliers,
        keyframes=keyframes,
        cpu_time=cpu,
        lost=lost,
        meta={"params": params.model_dump()},
    )
