"""Accuracy of a 3-D camera trajectory: ATE after SE(3) / Sim(3) alignment, and KITTI's relative error over segments.

Poses are ``T_world←cam`` (K, 4, 4), estimate ``P_k`` and reference ``Q_k`` at the same frames.

**Alignment** (Umeyama 1991, in 3D): with positions p_k (estimate), q_k (reference), ::

    μ_p, μ_q means;  σ_p² = mean ||p_k − μ_p||²;  Σ = mean (q_k − μ_q)(p_k − μ_p)ᵀ  (3, 3) = U D Vᵀ
    S = diag(1, 1, det U · det V);  R = U S Vᵀ;  s = tr(D S)/σ_p² (Sim(3); 1 for SE(3));  t = μ_q − s R μ_p

**ATE** = sqrt(mean ||s R p_k + t − q_k||²) [m] (Sturm et al. 2012), also as % of the reference path length.

**KITTI relative error** (Geiger et al. 2012, the odometry devkit's ``calcSequenceErrors``): from every ``step``-th
first frame i and for each segment length L, the first frame j whose distance along the reference from i is ≥ L;
the error pose ``E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)`` gives ``t_err = ||trans(E)|| / L`` and ``r_err = angle(E) / L``;
the averages over all (i, L) are ``t_rel`` [%] and ``r_rel`` [deg / 100 m]. (The devkit uses L = 100 … 800 m and
step 10; shorter sequences need shorter L, which the caller states.) Drift: the end-point position error after
SE(3) alignment of the first pose only (the start pose is given), as % of the distance travelled.

**As metrics of the registry** (``ate3d``, ``kitti_rel``; :func:`ate3d`, :func:`relative3d`): the estimate's
``poses_3d`` against the camera's ground truth (``Sequence.camera.ground_truth``) at the same frames (the estimate's
times are camera times, matched to 1 µs). ``ate3d`` gives the ATE after SE(3) (metric methods: stereo) and after
Sim(3) (monocular: the scale is unobservable) side by side; ``kitti_rel`` gives t_rel, r_rel and the drift at the
estimate's own scale and t_rel again at the Sim(3) alignment's scale (the monocular number: its scale drift, not the
unobservable global scale). The segment lengths and the step are the config's (the devkit's 100–800 m and 10 by
default).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field, PositiveFloat

from slamarena.datasets.estimate import Estimate
from slamarena.params import Params

from .reference import MetricUnavailable

__all__ = [
    "align_umeyama",
    "ate_3d",
    "kitti_relative_error",
    "path_length",
    "end_point_drift",
    "camera_reference",
    "ATE3DParams",
    "RelativeErrorParams",
    "ATE3D_OUTPUTS",
    "RELATIVE3D_OUTPUTS",
    "ate3d",
    "relative3d",
]


def align_umeyama(p: np.ndarray, q: np.ndarray, with_scale: bool) -> tuple[float, np.ndarray, np.ndarray]:
    """(s, R (3, 3), t (3,)) minimising Σ ||q_k − (s R p_k + t)||² over positions p, q (K, 3)."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    mu_p, mu_q = p.mean(axis=0), q.mean(axis=0)
    dp, dq = p - mu_p, q - mu_q
    U, D, Vt = np.linalg.svd(dq.T @ dp / len(p))
    S = np.diag([1.0, 1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0])
    R = U @ S @ Vt
    s = float(np.trace(np.diag(D) @ S) / np.mean(np.sum(dp**2, axis=1))) if with_scale else 1.0
    return s, R, mu_q - s * R @ mu_p


def path_length(poses: np.ndarray) -> np.ndarray:
    """(K,) distance travelled along the positions of ``poses`` (K, 4, 4) up to each frame [m]."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1))])


def ate_3d(estimate: np.ndarray, reference: np.ndarray, align: str = "se3") -> dict:
    """ATE after ``align`` (``se3`` or ``sim3``): rmse [m], its % of the reference path length, max, scale."""
    if align not in ("se3", "sim3"):
        raise ValueError(f"align must be se3 or sim3, got {align!r}")
    p, q = estimate[:, :3, 3], reference[:, :3, 3]
    s, R, t = align_umeyama(p, q, with_scale=align == "sim3")
    e = np.linalg.norm(s * p @ R.T + t - q, axis=1)
    rmse = float(np.sqrt(np.mean(e**2)))
    return {
        "rmse": rmse,
        "rmse_percent_of_path": 100 * rmse / float(path_length(reference)[-1]),
        "max": float(e.max()),
        "scale": s,
    }


def _angle(R: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0))


def kitti_relative_error(estimate: np.ndarray, reference: np.ndarray, lengths, step: int = 10) -> dict:
    """t_rel [%] and r_rel [deg / 100 m] averaged over all segments, and per length; the number of segments."""
    distance = path_length(reference)
    t_errors, r_errors, per_length = [], [], {}
    for L in lengths:
        tl, rl = [], []
        for i in range(0, len(reference), step):
            j = int(np.searchsorted(distance, distance[i] + L))
            if j >= len(reference):
                break
            dQ = np.linalg.inv(reference[i]) @ reference[j]
            dP = np.linalg.inv(estimate[i]) @ estimate[j]
            E = np.linalg.inv(dQ) @ dP
            tl.append(np.linalg.norm(E[:3, 3]) / L)
            rl.append(_angle(E[:3, :3]) / L)
        per_length[float(L)] = {
            "segments": len(tl),
            "t_rel_percent": 100 * float(np.mean(tl)) if tl else None,
            "r_rel_deg_per_100m": float(np.degrees(np.mean(rl)) * 100) if rl else None,
        }
        t_errors += tl
        r_errors += rl
    if not t_errors:
        raise ValueError(f"no segment of lengths {list(lengths)} fits in {distance[-1]:.1f} m")
    return {
        "t_rel_percent": 100 * float(np.mean(t_errors)),
        "r_rel_deg_per_100m": float(np.degrees(np.mean(r_errors)) * 100),
        "segments": len(t_errors),
        "per_length": per_length,
    }


def end_point_drift(estimate: np.ndarray, reference: np.ndarray) -> dict:
    """The last position's error [m] with both trajectories expressed from their first pose, and its % of the path."""
    p = np.linalg.inv(estimate[0]) @ estimate[-1]
    q = np.linalg.inv(reference[0]) @ reference[-1]
    error = float(np.linalg.norm(p[:3, 3] - q[:3, 3]))
    return {"error_m": error, "percent_of_path": 100 * error / float(path_length(reference)[-1])}


def camera_reference(estimate: Estimate, data) -> tuple[np.ndarray, np.ndarray]:
    """(P, Q) (K, 4, 4): the estimate's ``poses_3d`` and the camera's ground truth at the same frames."""
    if estimate.poses_3d is None:
        raise MetricUnavailable(f"{estimate.method} gives no 3-D trajectory (Estimate.poses_3d)")
    camera = getattr(data, "camera", None)
    if camera is None or camera.ground_truth is None:
        raise MetricUnavailable("the dataset has no camera ground truth")
    index = np.clip(np.searchsorted(camera.t, estimate.t), 0, len(camera.t) - 1)
    if not np.all(np.abs(camera.t[index] - estimate.t) <= 1e-6):
        raise MetricUnavailable("the estimate's times are not the camera's frame times")
    return estimate.poses_3d, camera.ground_truth[index]


class ATE3DParams(Params):
    """The 3-D ATE takes no parameters: it reports the SE(3) and the Sim(3) alignment side by side."""


ATE3D_OUTPUTS = {
    "rmse": ("lower", "3-D ATE after SE(3) alignment [m]"),
    "percent": ("lower", "3-D ATE after SE(3) alignment [% of the path length]"),
    "sim3_rmse": ("lower", "3-D ATE after Sim(3) alignment [m]"),
    "sim3_percent": ("lower", "3-D ATE after Sim(3) alignment [% of the path length] (monocular)"),
    "sim3_scale": (None, "scale of the Sim(3) alignment (estimate → reference)"),
    "path_m": (None, "length of the reference path [m]"),
}


def ate3d(estimate: Estimate, data, params: ATE3DParams = ATE3DParams()) -> tuple[dict, dict]:
    P, Q = camera_reference(estimate, data)
    se3, sim3 = ate_3d(P, Q, "se3"), ate_3d(P, Q, "sim3")
    s, R, t = align_umeyama(P[:, :3, 3], Q[:, :3, 3], with_scale=False)
    error = np.linalg.norm(P[:, :3, 3] @ R.T + t - Q[:, :3, 3], axis=1)
    out = {
        "rmse": se3["rmse"],
        "percent": se3["rmse_percent_of_path"],
        "sim3_rmse": sim3["rmse"],
        "sim3_percent": sim3["rmse_percent_of_path"],
        "sim3_scale": sim3["scale"],
        "path_m": float(path_length(Q)[-1]),
    }
    return out, {"t": estimate.t, "distance": path_length(Q), "error": error}


class RelativeErrorParams(Params):
    """Segment lengths and the step between first frames of KITTI's relative error."""

    lengths: list[PositiveFloat] = Field(
        [100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0, 800.0],
        min_length=1,
        description="segment lengths along the reference [m] (the devkit's 100–800 m by default)",
    )
    step: int = Field(10, ge=1, description="frames between the first frames of the segments (the devkit's 10)")


RELATIVE3D_OUTPUTS = {
    "t_rel_percent": ("lower", "KITTI translational error over the segments [%]"),
    "r_rel_deg_per_100m": ("lower", "KITTI rotational error over the segments [deg / 100 m]"),
    "t_rel_sim3_percent": ("lower", "KITTI translational error at the Sim(3) alignment's scale [%] (monocular)"),
    "drift_percent": ("lower", "end-point position error from the first pose [% of the path]"),
    "segments": (None, "segments averaged"),
}


def relative3d(estimate: Estimate, data, params: RelativeErrorParams = RelativeErrorParams()) -> tuple[dict, dict]:
    P, Q = camera_reference(estimate, data)
    try:
        metric = kitti_relative_error(P, Q, params.lengths, params.step)
    except ValueError as exc:
        raise MetricUnavailable(str(exc)) from None
    scaled = P.copy()
    scaled[:, :3, 3] *= ate_3d(P, Q, "sim3")["scale"]
    out = {
        "t_rel_percent": metric["t_rel_percent"],
        "r_rel_deg_per_100m": metric["r_rel_deg_per_100m"],
        "t_rel_sim3_percent": kitti_relative_error(scaled, Q, params.lengths, params.step)["t_rel_percent"],
        "drift_percent": end_point_drift(P, Q)["percent_of_path"],
        "segments": metric["segments"],
    }
    return out, {}
