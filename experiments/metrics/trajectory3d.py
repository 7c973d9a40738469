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
"""

from __future__ import annotations

import numpy as np

__all__ = ["align_umeyama", "ate_3d", "kitti_relative_error", "path_length", "end_point_drift"]


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
