"""Monocular visual odometry: a two-view start, PnP tracking against triangulated keyframe points, new keyframes.

Model. The camera pose ``T_world←cam`` per frame, the world frame the first frame's camera. Scale is unobservable:
the start fixes it by ``||t|| = 1`` between the first two keyframes; the trajectory is evaluated after a Sim(3)
alignment, and the scale drifts.

Start: frame 0 is keyframe 0. Its ORB features are matched to those of frames 1, 2, …; the first frame whose matches
have a median image displacement ≥ ``init_parallax`` px becomes keyframe 1: the essential matrix by RANSAC
(:mod:`.backends`: 5-point, Sampson threshold ``essential_threshold`` px / fx) gives (R, t) = T_1←0, ||t|| = 1, and
its inliers are triangulated (DLT) into map points. The frames between are then tracked like any other.

Per frame (tracking): ORB matched to the map points of the last ``map_keyframes`` keyframe pairs, the pose by PnP
RANSAC + LM (``pnp_threshold`` px); each inlier map point takes the descriptor of its latest view (appearance
changes under forward motion). A frame becomes a keyframe when its inliers fall below ``keyframe_inliers`` × the
first inliers against the current map, or below 2 × ``min_inliers``; then the features it shares with the previous
keyframe (descriptor matches, ratio and mutual checks) are triangulated with both poses and kept when they lie in
front of both cameras, reproject within ``pnp_threshold`` px in both, and are seen under a parallax angle of at
least ``min_parallax_deg`` — provided the median displacement of those features since the previous keyframe is at
least ``init_parallax`` px (a keyframe needs a baseline), unless the frame is about to be lost (fewer than
2 × ``min_inliers`` inliers). A frame whose PnP fails keeps the previous pose and is counted as lost.

The map: points (N, 3), each with its latest descriptor and the latest keyframe that saw it; the local map is the
points seen by the last ``map_keyframes`` keyframes. A keyframe observes its PnP inliers (monocular ``(u, v)``) and
the new points it triangulates with the previous keyframe (from features neither keyframe has mapped yet).
Features: ORB spread over a grid of buckets (:func:`.features.detect`).

Back end (``window`` ≥ 3): after each new keyframe, :func:`.window_ba.bundle_adjust` (no baseline: projection
factors, Huber) over the last ``window`` keyframes and the points at least two of them see, the two oldest held
fixed — seven degrees of gauge freedom, the scale among them, fixed by two poses —; frames tracked against a moved
keyframe move with it. A failed adjustment leaves the estimate as it was and is recorded in ``meta``.

``pnp_threshold``, ``min_inliers``, ``keyframe_inliers``, ``seed`` and ``geometry`` are the fields of ``tracking``
(:class:`.stereo_vo.TrackingParams`, shared with the stereo pipeline); ``map_keyframes`` is each pipeline's own (2
stereo, 3 mono: a partial ``tracking`` override takes the class defaults, so a default that differs stays outside).
"""

from __future__ import annotations

import time

import numpy as np
from pydantic import field_validator

from slamarena.datasets.sequence import Camera
from slamarena.estimators.gtsam_smoother.graph import OptimizationError
from slamarena.params import Field, Params

from .backends import BACKENDS, Backend
from .features import FeatureParams, detect
from .projection import normalise, residuals
from .stereo_vo import TrackingParams, VOResult, pose_matrix
from .window_ba import Observation, bundle_adjust

__all__ = ["MonoVOParams", "mono_vo", "triangulate_pair"]


class MonoVOParams(Params):
    """Monocular VO parameters. init_parallax, min_parallax_deg and map_keyframes were changed (from 20 px, 1°, 2)
    after the first run failed on frames 0–60 of KITTI 00, part of the scored frames
    (research/notebook/2026-11-28-vision.md)."""

    features: FeatureParams = Field(FeatureParams(), description="ORB features and their matching")
    init_parallax: float = Field(10.0, gt=0, description="median displacement that starts the map [px]")
    essential_threshold: float = Field(1.0, gt=0, description="Sampson threshold of the essential RANSAC [px]")
    min_parallax_deg: float = Field(0.5, ge=0, description="smallest parallax angle of a new map point [deg]")
    tracking: TrackingParams = Field(
        TrackingParams(), description="PnP tracking, keyframes, whose geometry (pnp_threshold also gates triangulation)"
    )
    map_keyframes: int = Field(3, ge=1, description="the keyframes whose points form the local map")
    window: int = Field(0, ge=0, description="keyframes of the windowed bundle adjustment (0: none; else ≥ 3)")

    @field_validator("window")
    @classmethod
    def _window(cls, window: int) -> int:
        if window in (1, 2):
            raise ValueError("a monocular window holds its two oldest keyframes fixed: 0 (none) or at least 3")
        return window


def triangulate_pair(
    backend: Backend,
    K: np.ndarray,
    u1: np.ndarray,
    u2: np.ndarray,
    pose1: tuple[np.ndarray, np.ndarray],
    pose2: tuple[np.ndarray, np.ndarray],
    threshold: float,
    min_parallax_deg: float,
) -> tuple[np.ndarray, np.ndarray]:
    """World points (m, 3) of matched pixels u1, u2 (n, 2) seen from poses T_cam←world, and the kept mask (n,)."""
    X = backend.triangulate(normalise(K, u1), normalise(K, u2), pose1, pose2)
    finite = np.isfinite(X).all(axis=1)
    keep = finite.copy()
    X_safe = np.where(finite[:, None], X, 0.0)
    centres = []
    for (R, t), u in ((pose1, u1), (pose2, u2)):
        depth = X_safe @ R[2] + t[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.linalg.norm(residuals(K, R, t, X_safe, u), axis=1)
        keep &= (depth > 0) & (error <= threshold)
        centres.append(-R.T @ t)
    ray1, ray2 = X_safe - centres[0], X_safe - centres[1]
    cos = np.sum(ray1 * ray2, axis=1) / np.maximum(np.linalg.norm(ray1, axis=1) * np.linalg.norm(ray2, axis=1), 1e-300)
    keep &= cos <= np.cos(np.radians(min_parallax_deg))
    return X[keep], keep


def mono_vo(camera: Camera, params: MonoVOParams | None = None) -> VOResult:
    """Run monocular VO over every frame of ``camera`` (see the module docstring); ValueError when the start fails."""
    params = MonoVOParams.of(params)
    backend = BACKENDS[params.tracking.geometry]
    K, n = camera.K, len(camera)
    poses = np.tile(np.eye(4), (n, 1, 1))
    reference = np.zeros(n, np.int64)  # the keyframe each frame was tracked against
    inliers = np.full(n, -1, np.int64)
    cpu = np.zeros(n)
    features: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    # every map point (world), its descriptor (its latest inlier view), the latest keyframe that saw it; each
    # keyframe's observations and the features it has mapped
    points, descriptors, last_seen = np.zeros((0, 3)), np.zeros((0, 32), np.uint8), np.zeros(0, np.int64)
    observations: dict[int, list[Observation]] = {}
    mapped: dict[int, np.ndarray] = {}
    ba_runs, ba_failures = 0, []

    def features_of(k: int):
        if k not in features:
            features[k] = detect(camera.image(k), params.features)
        return features[k]

    def add_points(k0: int, k1: int, a: np.ndarray, b: np.ndarray, X: np.ndarray) -> None:
        """New points X (m, 3) seen by keyframes k0 at its features a (m,) and k1 at its features b (m,)."""
        nonlocal points, descriptors, last_seen
        ids = len(points) + np.arange(len(X))
        points = np.vstack([points, X])
        descriptors = np.vstack([descriptors, features_of(k1)[1][b]])
        last_seen = np.concatenate([last_seen, np.full(len(X), k1)])
        for k, f in ((k0, a), (k1, b)):
            observations.setdefault(k, []).extend(Observation(k, int(p), *features_of(k)[0][i]) for p, i in zip(ids, f))
            mapped[k] = np.union1d(mapped.get(k, np.zeros(0, np.int64)), f)

    def adjust(keyframes: list[int]) -> None:
        """Bundle adjustment over the last ``window`` keyframes, the oldest two fixed (the gauge and the scale)."""
        nonlocal ba_runs
        window = keyframes[-params.window :]
        try:
            new_poses, new_points = bundle_adjust(
                K, None, {k: poses[k] for k in window}, points, [o for k in window for o in observations[k]],
                tuple(window[:2]), min_views=2, max_iterations=100,
            )  # fmt: skip
        except (OptimizationError, RuntimeError) as failure:
            ba_failures.append(f"window {window}: {failure}"[:200])
            return
        ba_runs += 1
        for k in window[2:]:  # frames tracked against a moved keyframe move with it
            move = new_poses[k] @ np.linalg.inv(poses[k])
            later = np.flatnonzero((reference == k) & (np.arange(n) > k) & (np.arange(n) <= keyframes[-1]))
            poses[later] = move @ poses[later]
            poses[k] = new_poses[k]
        for p, X in new_points.items():
            points[p] = X

    # ---- start: keyframes 0 and k1
    start = time.process_time()
    u0, d0 = features_of(0)
    cpu[0] = time.process_time() - start
    for k1 in range(1, n):
        start = time.process_time()
        u1, d1 = features_of(k1)
        a, b = backend.match(d0, d1, params.features.ratio, params.features.max_distance)
        cpu[k1] += time.process_time() - start
        if len(a) >= 8 and np.median(np.linalg.norm(u1[b] - u0[a], axis=1)) >= params.init_parallax:
            break
    else:
        raise ValueError(f"mono VO: no frame has a median displacement of {params.init_parallax} px from frame 0")
    start = time.process_time()
    two_view = backend.essential(normalise(K, u0[a]), normalise(K, u1[b]), params.essential_threshold / K[0, 0], 0)
    if two_view is None or two_view.inliers.sum() < 8:
        raise ValueError(f"mono VO: no essential matrix between frames 0 and {k1}")
    first, second = (np.eye(3), np.zeros(3)), (two_view.R, two_view.t)
    a, b = a[two_view.inliers], b[two_view.inliers]
    X, keep = triangulate_pair(
        backend, K, u0[a], u1[b], first, second, params.tracking.pnp_threshold, params.min_parallax_deg
    )
    poses[k1] = pose_matrix(*second)
    keyframes = [0, k1]
    add_points(0, k1, a[keep], b[keep], X)
    reference[1:] = k1
    cpu[k1] += time.process_time() - start

    # ---- tracking: the frames between the two keyframes, then the rest
    first_inliers, lost = None, 0
    for k in [*range(1, k1), *range(k1 + 1, n)]:
        start = time.process_time()
        u, d = features_of(k)
        local = np.flatnonzero(np.isin(last_seen, keyframes[-params.map_keyframes :]))
        i, j = backend.match(d, descriptors[local], params.features.ratio, params.features.max_distance)
        result = backend.pnp(K, points[local[j]], u[i], params.tracking.pnp_threshold, params.tracking.seed + k)
        count = 0 if result is None else int(result.inliers.sum())
        inliers[k] = count
        if k > k1:
            reference[k] = keyframes[-1]
        if result is None or count < params.tracking.min_inliers:
            poses[k] = poses[k - 1]
            lost += 1
        else:
            poses[k] = pose_matrix(result.R, result.t)
            first_inliers = count if first_inliers is None else first_inliers
            descriptors[local[j[result.inliers]]] = d[i[result.inliers]]  # a map point looks like its latest view
        if (
            k > k1
            and result is not None
            and count >= params.tracking.min_inliers
            and (count < params.tracking.keyframe_inliers * first_inliers or count < 2 * params.tracking.min_inliers)
        ):
            previous = keyframes[-1]
            up, dp = features_of(previous)
            tracked, ids = i[result.inliers], local[j[result.inliers]]
            a, b = backend.match(dp, d, params.features.ratio, params.features.max_distance)
            fresh = ~np.isin(a, mapped.get(previous, [])) & ~np.isin(b, tracked)  # not yet map points
            a, b = a[fresh], b[fresh]
            T_prev, T_now = np.linalg.inv(poses[previous]), np.linalg.inv(poses[k])
            moved = len(a) >= 8 and np.median(np.linalg.norm(u[b] - up[a], axis=1)) >= params.init_parallax
            X, keep = triangulate_pair(
                backend, K, up[a], u[b], (T_prev[:3, :3], T_prev[:3, 3]), (T_now[:3, :3], T_now[:3, 3]),
                params.tracking.pnp_threshold, params.min_parallax_deg,
            )  # fmt: skip
            keep &= moved or count < 2 * params.tracking.min_inliers  # about to be lost: any baseline will do
            if keep.sum() >= params.tracking.min_inliers:
                keyframes.append(k)
                observations[k] = [Observation(k, int(p), *u[f]) for p, f in zip(ids, tracked)]
                mapped[k] = np.sort(tracked)
                last_seen[ids] = k
                add_points(previous, k, a[keep], b[keep], X)
                first_inliers = None
                if params.window >= 3:
                    adjust(keyframes)
            for old in [f for f in features if f < keyframes[-1] and f not in keyframes[-1:]]:
                del features[old]
        cpu[k] += time.process_time() - start
    return VOResult(
        frames=np.arange(n),
        t=camera.t.copy(),
        poses=poses,
        inliers=inliers,
        keyframes=keyframes,
        cpu_time=cpu,
        lost=lost,
        meta={"params": params.model_dump(), "start_keyframe": k1, "ba_runs": ba_runs, "ba_failures": ba_failures},
    )
