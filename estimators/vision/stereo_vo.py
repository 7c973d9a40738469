"""Stereo visual odometry: points triangulated from the rectified pair, PnP tracking against a keyframe map.

Model. The left camera's pose ``T_world←cam`` (4, 4) per frame, the world frame the left camera of the first frame;
scale is metric (the baseline b). The map: points X (N, 3) in the world frame, each with an ORB descriptor (N, 32)
(its latest keyframe view), the keyframe whose stereo pair placed it (anchor) and the latest keyframe that saw it;
each keyframe's observations of them (stereo ``(u_L, u_R, v)`` or monocular ``(u, v)``).

Features: ORB spread over a grid of buckets (:func:`.features.detect`, ``features.grid``).

Stereo points of a keyframe: its left features matched by Hamming distance to the right image's among the pairs a
rectified pair allows (:func:`stereo_candidates`: same row within ``row_tolerance`` px, disparity ``d = u_L − u_R``
in ``[min_disparity, ∞)``; only those pairs' distances are computed), the disparity refined to a fraction of a pixel
(``subpixel``: :func:`.disparity.refine_disparity`, block matching along the row and a 1-D Lucas-Kanade step), then
DLT-triangulated (:func:`.triangulation.triangulate_dlt`) with the left camera ``[I | 0]`` and the right camera
``[I | (−b, 0, 0)ᵀ]`` on the left point's row (z = fx b / d on a rectified pair), moved to the world frame by the
keyframe's pose.

Per frame (tracking): the local map is the points seen by the last ``map_keyframes`` keyframes. Their projections
by the constant-velocity prediction ``T_k ≈ T_{k−1} T_{k−2}⁻¹ T_{k−1}`` (world←cam) pick the candidate features
within ``search_radius`` px (:func:`guided_candidates`), matched by Hamming distance (ratio test, mutual check among
the candidates); ``T_cam←world`` by :func:`.pnp.pnp_ransac` (P3P samples, ``pnp_threshold`` px, LM on the inliers).
If fewer than ``min_inliers`` survive, the frame is matched against the whole local map and PnP runs again.
A frame becomes a keyframe when its inliers fall below ``keyframe_inliers`` × the inliers of the first frame tracked
against the current keyframe, or below ``min_inliers`` × 2. Its tracked points (PnP inliers) stay the same points:
those its stereo pair also matches get a stereo observation and the keyframe's triangulation as their position (the
nearest view), the others a monocular observation; its untracked stereo matches become new points.
A frame whose PnP fails (fewer than ``min_inliers`` inliers) takes the previous pose (counted in ``lost``).

Back end (``window`` ≥ 2): after each new keyframe, :func:`.window_ba.bundle_adjust` over the last ``window``
keyframes and the points at least two of them see (a point one keyframe alone sees changes no pose: it moves with
its anchor), Huber kernel, the oldest keyframe held fixed; the frames tracked against a moved keyframe move with it
(the reported trajectory is the one after the adjustments). A failed adjustment leaves the estimate as it was and
is recorded in ``meta``.

Every frame of the sequence must have a right image (a rectified pair). ``geometry`` picks whose matching,
triangulation and PnP run (:mod:`.backends`: ``ours`` or ``opencv``, the OpenCV-only baseline). ``pnp_threshold``,
``min_inliers``, ``keyframe_inliers``, ``seed`` and ``geometry`` are the fields of ``tracking`` (:class:`TrackingParams`,
shared with the monocular pipeline).
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
from .features import FeatureParams, detect
from .window_ba import Observation, bundle_adjust

__all__ = [
    "StereoVOParams",
    "VOResult",
    "stereo_candidates",
    "stereo_matches",
    "stereo_points",
    "stereo_vo",
    "pose_matrix",
]


class TrackingParams(Params):
    """Tracking by PnP against the local map and the keyframe rule, shared by the stereo and monocular pipelines."""

    pnp_threshold: float = Field(2.0, gt=0, description="PnP RANSAC inlier threshold [px]")
    min_inliers: int = Field(20, ge=4, description="PnP inliers below which a frame is lost")
    keyframe_inliers: float = Field(0.6, gt=0, lt=1, description="new keyframe below this × the first inliers")
    seed: int = Field(0, ge=0, description="RANSAC's random seed")
    geometry: Literal["ours", "opencv"] = Field("ours", description="whose matching, triangulation and PnP")


class StereoVOParams(Params):
    """Stereo VO parameters (set a priori, not fitted to the scored frames)."""

    features: FeatureParams = Field(FeatureParams(), description="ORB features and their matching")
    row_tolerance: float = Field(1.0, ge=0, description="|v_l − v_r| of a stereo match on the rectified pair [px]")
    min_disparity: float = Field(2.0, gt=0, description="smallest disparity triangulated [px] (depth ≤ fx b / d)")
    tracking: TrackingParams = Field(TrackingParams(), description="PnP tracking, keyframes, whose geometry")
    map_keyframes: int = Field(2, ge=1, description="the keyframes whose points form the local map")
    window: int = Field(0, ge=0, description="keyframes of the windowed bundle adjustment (0: none)")
    subpixel: bool = Field(True, description="refine each stereo match's disparity to a fraction of a pixel")
    search_radius: float = Field(
        20.0,
        ge=0,
        description="match a frame's features to the map points projected within this radius by the "
        "constant-velocity prediction [px] (0: against every map point)",
    )


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


def stereo_candidates(
    u_left: np.ndarray, u_right: np.ndarray, row_tolerance: float, min_disparity: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (i (c,), j (c,)) of left (n_L, 2) and right (n_R, 2) keypoints a rectified pair allows:
    ``|v_L − v_R| ≤ row_tolerance`` and ``u_L − u_R ≥ min_disparity`` (the right keypoints sorted by row, a band of
    rows per left keypoint: c ≈ n_L × the keypoints in 2 × row_tolerance rows, not n_L × n_R)."""
    order = np.argsort(u_right[:, 1], kind="stable")
    rows = u_right[order, 1]
    low = np.searchsorted(rows, u_left[:, 1] - row_tolerance, "left")
    count = np.searchsorted(rows, u_left[:, 1] + row_tolerance, "right") - low
    i = np.repeat(np.arange(len(u_left)), count)
    j = order[np.repeat(low - np.cumsum(count) + count, count) + np.arange(count.sum())]
    keep = u_left[i, 0] - u_right[j, 0] >= min_disparity
    return i[keep], j[keep]


def guided_candidates(
    K: np.ndarray, predicted: np.ndarray, X: np.ndarray, u: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (feature i, map point j) whose pixel u_i (n, 2) lies within ``radius`` px of the projection of
    X_j (m, 3) (world) by the predicted pose ``T_world←cam`` (4, 4); points behind the camera have none."""
    from scipy.spatial import cKDTree

    R, t = predicted[:3, :3].T, -predicted[:3, :3].T @ predicted[:3, 3]
    Xc = X @ R.T + t
    ahead = np.flatnonzero(Xc[:, 2] > 0)
    projected = Xc[ahead, :2] / Xc[ahead, 2:] * np.diag(K)[:2] + K[:2, 2]
    if len(u) == 0 or len(ahead) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pairs = cKDTree(u).sparse_distance_matrix(cKDTree(projected), radius, output_type="ndarray")
    return pairs["i"].astype(np.int64), ahead[pairs["j"]]


def stereo_matches(
    camera: Camera, k: int, params: StereoVOParams, u: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frame k's stereo points among its left ORB features (pixels u (n, 2), descriptors d (n, 32)): the indices
    (m,) of the features matched in the right image, their right columns u_R (m,) and camera-frame points (m, 3)."""
    backend = BACKENDS[params.tracking.geometry]
    left, right = camera.image(k), camera.image(k, "right")
    ur, dr = detect(right, params.features)
    i, j = stereo_candidates(u, ur, params.row_tolerance, params.min_disparity)
    i, j = backend.match_candidates(d, dr, i, j, params.features.ratio, params.features.max_distance)
    ul, u_right = u[i], ur[j, 0]
    if params.subpixel:
        u_right, refined = refine_disparity(left, right, ul, u_right)
        refined &= ul[:, 0] - np.nan_to_num(u_right) >= params.min_disparity
        i, ul, u_right = i[refined], ul[refined], u_right[refined]
    K, b = camera.K, camera.baseline
    x_left = (ul - K[:2, 2]) / np.diag(K)[:2]
    x_right = (np.column_stack([u_right, ul[:, 1]]) - K[:2, 2]) / np.diag(K)[:2]  # rectified: the left row
    X = backend.triangulate(x_left, x_right, (np.eye(3), np.zeros(3)), (np.eye(3), np.array([-b, 0.0, 0.0])))
    good = np.isfinite(X).all(axis=1) & (X[:, 2] > 0)
    return i[good], u_right[good], X[good]


def stereo_points(
    camera: Camera, k: int, params: StereoVOParams
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frame k's stereo points: left pixels (n, 2), right columns u_R (n,), camera-frame points (n, 3), left
    descriptors (n, 32) (:func:`stereo_matches` on the left image's ORB features)."""
    u, d = detect(camera.image(k), params.features)
    i, u_right, X = stereo_matches(camera, k, params, u, d)
    return u[i], u_right, X, d[i]


def stereo_vo(camera: Camera, params: StereoVOParams | None = None) -> VOResult:
    """Run stereo VO over every frame of ``camera`` (see the module docstring)."""
    params = StereoVOParams.of(params)
    if camera.right is None or not camera.stereo.all():
        raise ValueError(f"stereo VO needs a right image for every frame; {int((~camera.stereo).sum())} lack one")
    backend = BACKENDS[params.tracking.geometry]
    n = len(camera)
    poses = np.tile(np.eye(4), (n, 1, 1))
    reference = np.zeros(n, np.int64)  # the keyframe each frame was tracked against
    inliers = np.full(n, -1, np.int64)
    cpu = np.zeros(n)
    keyframes: list[int] = []
    # every map point (world), its descriptor (the latest keyframe's view), the keyframe whose stereo pair gave its
    # position (anchor) and the latest keyframe that saw it; each keyframe's observations
    points = np.zeros((0, 3))
    descriptors = np.zeros((0, 32), np.uint8)
    anchor = np.zeros(0, np.int64)
    last_seen = np.zeros(0, np.int64)
    observations: dict[int, list[Observation]] = {}
    first_inliers, lost, ba_runs, ba_failures = None, 0, 0, []

    def add_keyframe(k: int, u: np.ndarray, d: np.ndarray, tracked: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Frame k (features u, d) becomes a keyframe; ``tracked`` = (feature indices, map point ids) of its PnP
        inliers. A tracked point matched in the right image gets a stereo observation and the new triangulation as
        its position; an untracked stereo match becomes a new point."""
        nonlocal first_inliers, points, descriptors, anchor, last_seen
        index, u_right, Xc = stereo_matches(camera, k, params, u, d)
        features, ids = tracked if tracked is not None else (np.zeros(0, np.int64), np.zeros(0, np.int64))
        point_of = np.full(len(u), -1)
        point_of[features] = ids
        old = point_of[index] >= 0
        new_ids = len(points) + np.arange(int((~old).sum()))
        stereo_ids = point_of[index].copy()
        stereo_ids[~old] = new_ids
        X_world = Xc @ poses[k, :3, :3].T + poses[k, :3, 3]
        points = np.vstack([points, X_world[~old]])
        descriptors = np.vstack([descriptors, d[index[~old]]])
        anchor = np.concatenate([anchor, np.full(len(new_ids), k)])
        last_seen = np.concatenate([last_seen, np.full(len(new_ids), k)])
        points[stereo_ids[old]], anchor[stereo_ids[old]] = X_world[old], k
        descriptors[ids], last_seen[ids] = d[features], k
        mono = np.setdiff1d(np.arange(len(features)), np.flatnonzero(np.isin(features, index)))
        observations[k] = [Observation(k, int(p), *u[f], r) for p, f, r in zip(stereo_ids, index, u_right)] + [
            Observation(k, int(ids[m]), *u[features[m]]) for m in mono
        ]
        keyframes.append(k)
        first_inliers = None
        if params.window >= 2 and len(keyframes) >= 2:
            adjust()

    def adjust() -> None:
        nonlocal ba_runs
        window = keyframes[-params.window :]
        try:
            new_poses, new_points = bundle_adjust(
                camera.K,
                camera.baseline,
                {k: poses[k] for k in window},
                points,
                [o for k in window for o in observations[k]],
                (window[0],),
                min_views=2,
            )
        except (OptimizationError, RuntimeError) as failure:
            ba_failures.append(f"window {window}: {failure}"[:200])
            return
        ba_runs += 1
        adjusted = np.zeros(len(points), bool)
        adjusted[list(new_points)] = True
        for k in window:  # frames tracked against a moved keyframe, and the points it alone places, move with it
            move = new_poses[k] @ np.linalg.inv(poses[k])
            later = np.flatnonzero((reference == k) & (np.arange(n) > k) & (np.arange(n) <= keyframes[-1]))
            poses[later] = move @ poses[later]
            poses[k] = new_poses[k]
            own = (anchor == k) & ~adjusted
            points[own] = points[own] @ move[:3, :3].T + move[:3, 3]
        for p, X in new_points.items():
            points[p] = X

    for k in range(n):
        start = time.process_time()
        u, d = detect(camera.image(k), params.features)
        if k == 0:
            add_keyframe(0, u, d, None)
            cpu[k] = time.process_time() - start
            continue
        local = np.flatnonzero(np.isin(last_seen, keyframes[-params.map_keyframes :]))
        predicted = poses[k - 1] @ np.linalg.inv(poses[k - 2]) @ poses[k - 1] if k >= 2 else poses[0]
        for guided in (params.search_radius > 0, False):  # full matching when the guided search loses the frame
            if guided:
                i, j = guided_candidates(camera.K, predicted, points[local], u, params.search_radius)
                i, j = backend.match_candidates(
                    d, descriptors[local], i, j, params.features.ratio, params.features.max_distance
                )
            else:
                i, j = backend.match(d, descriptors[local], params.features.ratio, params.features.max_distance)
            result = backend.pnp(
                camera.K, points[local[j]], u[i], params.tracking.pnp_threshold, params.tracking.seed + k
            )
            count = 0 if result is None else int(result.inliers.sum())
            if count >= params.tracking.min_inliers:
                break
        inliers[k] = count
        reference[k] = keyframes[-1]
        if result is None or count < params.tracking.min_inliers:
            poses[k] = poses[k - 1]
            lost += 1
            add_keyframe(k, u, d, None)
        else:
            poses[k] = pose_matrix(result.R, result.t)
            first_inliers = count if first_inliers is None else first_inliers
            if count < params.tracking.keyframe_inliers * first_inliers or count < 2 * params.tracking.min_inliers:
                add_keyframe(k, u, d, (i[result.inliers], local[j[result.inliers]]))
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
