"""Windowed bundle adjustment over the last keyframes and the points they see (GTSAM), the VO back end.

Variables: the poses ``T_world←cam`` of the window's keyframes (Pose3) and the world points (Point3) they observe.
Factors, each with a Huber kernel (width ``robust_k`` whitened units) on isotropic pixel noise σ:

- a stereo observation ``(u_L, u_R, v)`` of a rectified pair: ``GenericStereoFactor3D`` with ``Cal3_S2Stereo(fx, fy,
  0, cx, cy, b)``: residual (3,) = π_stereo(T⁻¹ X) − (u_L, u_R, v), π_stereo(x, y, z) = (fx x/z + cx,
  fx (x − b)/z + cx, fy y/z + cy);
- a monocular observation ``(u, v)``: ``GenericProjectionFactorCal3_S2``, residual (2,) = π(T⁻¹ X) − (u, v)
  (the projection of :mod:`.projection`);
- a prior holding the oldest keyframe of the window where it is (σ 1e-6): the window's gauge (and, monocular, its
  scale comes from the points' positions: the window keeps two fixed keyframes in that case).

A point enters the window when it has a stereo observation in it, or monocular observations from two keyframes of it,
and at least ``min_views`` keyframes of the window see it.
Levenberg-Marquardt through :func:`slamarena.estimators.gtsam_smoother.graph.optimize` (a failure is an error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slamarena.robust import RobustKernelParams, robustify

__all__ = ["Observation", "bundle_adjust"]


@dataclass(frozen=True)
class Observation:
    """Keyframe ``keyframe`` sees point ``point`` at (u, v) [px] (left image) and, for a stereo observation, at u_right."""

    keyframe: int
    point: int
    u: float
    v: float
    u_right: float = np.nan


def bundle_adjust(
    K: np.ndarray,
    baseline: float | None,
    poses: dict[int, np.ndarray],
    points: np.ndarray,
    observations: list[Observation],
    fixed: tuple[int, ...],
    sigma_px: float = 1.0,
    robust_k: float = 1.345,
    min_views: int = 1,
    max_iterations: int = 20,
) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Optimise the keyframe poses ``poses`` (keyframe → T_world←cam (4, 4)) and the points (ids → rows of
    ``points`` (N, 3)) they observe; keyframes ``fixed`` are held by priors. ``min_views`` = 2 leaves out the
    points a single keyframe sees (their optimum is that keyframe's triangulation whatever its pose: they change no
    pose, only the size of the problem). Returns the new poses and the new
    positions of the points that entered the window."""
    import gtsam

    from slamarena.estimators.gtsam_smoother.graph import OptimizerParams, optimize

    X, L = gtsam.symbol_shorthand.X, gtsam.symbol_shorthand.L
    kernel = RobustKernelParams(robust="huber", robust_k=robust_k)
    mono_noise = robustify(gtsam.noiseModel.Isotropic.Sigma(2, sigma_px), kernel)
    stereo_noise = robustify(gtsam.noiseModel.Isotropic.Sigma(3, sigma_px), kernel)
    calibration = gtsam.Cal3_S2(K[0, 0], K[1, 1], 0.0, K[0, 2], K[1, 2])
    stereo_calibration = (
        gtsam.Cal3_S2Stereo(K[0, 0], K[1, 1], 0.0, K[0, 2], K[1, 2], baseline) if baseline is not None else None
    )
    window = [o for o in observations if o.keyframe in poses]
    seen: dict[int, set[int]] = {}
    stereo_points = set()
    for o in window:
        seen.setdefault(o.point, set()).add(o.keyframe)
        if np.isfinite(o.u_right):
            stereo_points.add(o.point)
    used = {p for p, frames in seen.items() if len(frames) >= max(min_views, 1 if p in stereo_points else 2)}
    graph, initial = gtsam.NonlinearFactorGraph(), gtsam.Values()
    for k, T in poses.items():
        initial.insert(X(k), gtsam.Pose3(T))
    for k in fixed:
        graph.add(gtsam.PriorFactorPose3(X(k), gtsam.Pose3(poses[k]), gtsam.noiseModel.Isotropic.Sigma(6, 1e-6)))
    for p in used:
        initial.insert(L(p), gtsam.Point3(*points[p]))
    for o in window:
        if o.point not in used:
            continue
        if np.isfinite(o.u_right):
            graph.add(
                gtsam.GenericStereoFactor3D(
                    gtsam.StereoPoint2(o.u, o.u_right, o.v), stereo_noise, X(o.keyframe), L(o.point), stereo_calibration
                )
            )
        else:
            graph.add(
                gtsam.GenericProjectionFactorCal3_S2(
                    gtsam.Point2(o.u, o.v), mono_noise, X(o.keyframe), L(o.point), calibration
                )
            )
    values = optimize(graph, initial, OptimizerParams(max_iterations=max_iterations, relative_error_tol=1e-6)).values
    return (
        {k: values.atPose3(X(k)).matrix() for k in poses},
        {p: np.asarray(values.atPoint3(L(p))) for p in used},
    )
