"""Triangulation of points seen by two calibrated cameras: linear DLT and the midpoint of the rays.

Camera k has pose ``T_k = (R_k, t_k)`` (``T_cam←world``: x_c = R_k X + t_k), projection ``P_k = [R_k | t_k]`` (3, 4)
on normalised image coordinates ``x_k = (u − cx)/fx, (v − cy)/fy`` (n, 2).

DLT (Hartley & Zisserman 2004, §12.2): the homogeneous X (4,) minimises ||A X|| with ||X|| = 1, ::

    A = [x_1 P_1³ − P_1¹;  y_1 P_1³ − P_1²;  x_2 P_2³ − P_2¹;  y_2 P_2³ − P_2²]      (4, 4), Pᵏ the k-th row

the right singular vector of the smallest singular value (batched SVD over the n points).

Midpoint: the rays ``c_k + s_k d_k`` (centre c_k = −R_kᵀ t_k, direction d_k = R_kᵀ (x_k, y_k, 1)) are closest at ::

    [d_1·d_1  −d_1·d_2; d_1·d_2  −d_2·d_2] (s_1, s_2)ᵀ = ((c_2 − c_1)·d_1, (c_2 − c_1)·d_2)ᵀ

and X is the midpoint of the two closest points (parallel rays: NaN).
"""

from __future__ import annotations

import numpy as np

__all__ = ["triangulate_dlt", "triangulate_midpoint", "depths"]


def _projection(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.asarray(R, float), np.asarray(t, float).reshape(3)])


def triangulate_dlt(x1: np.ndarray, x2: np.ndarray, pose1, pose2) -> np.ndarray:
    """World points (n, 3) of the normalised observations x1, x2 (n, 2) by the linear DLT (points at infinity: NaN)."""
    P1, P2 = _projection(*pose1), _projection(*pose2)
    x1, x2 = np.asarray(x1, float).reshape(-1, 2), np.asarray(x2, float).reshape(-1, 2)
    A = np.stack(
        [
            x1[:, :1] * P1[2] - P1[0],
            x1[:, 1:] * P1[2] - P1[1],
            x2[:, :1] * P2[2] - P2[0],
            x2[:, 1:] * P2[2] - P2[1],
        ],
        axis=1,
    )  # (n, 4, 4)
    X = np.linalg.svd(A)[2][:, -1, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        return X[:, :3] / X[:, 3:]


def triangulate_midpoint(x1: np.ndarray, x2: np.ndarray, pose1, pose2) -> np.ndarray:
    """World points (n, 3): the midpoints of the closest points of the two viewing rays (parallel rays: NaN)."""
    (R1, t1), (R2, t2) = pose1, pose2
    c1, c2 = -np.asarray(R1).T @ np.asarray(t1), -np.asarray(R2).T @ np.asarray(t2)
    d1 = np.column_stack([np.asarray(x1, float).reshape(-1, 2), np.ones(len(x1))]) @ np.asarray(R1)
    d2 = np.column_stack([np.asarray(x2, float).reshape(-1, 2), np.ones(len(x2))]) @ np.asarray(R2)
    b = c2 - c1
    a11, a12, a22 = (d1 * d1).sum(1), (d1 * d2).sum(1), (d2 * d2).sum(1)
    r1, r2 = d1 @ b, d2 @ b
    det = a12 * a12 - a11 * a22  # of [[a11, -a12], [a12, -a22]]
    with np.errstate(divide="ignore", invalid="ignore"):
        s1 = (-a22 * r1 + a12 * r2) / det
        s2 = (-a12 * r1 + a11 * r2) / det
        s1, s2 = (
            np.where(np.abs(det) > 1e-12 * a11 * a22, s1, np.nan),
            np.where(np.abs(det) > 1e-12 * a11 * a22, s2, np.nan),
        )
    return (c1 + s1[:, None] * d1 + c2 + s2[:, None] * d2) / 2


def depths(X: np.ndarray, pose) -> np.ndarray:
    """Depths z_c (n,) of world points X (n, 3) in the camera of ``pose`` = (R, t)."""
    R, t = pose
    return X @ np.asarray(R)[2] + float(np.asarray(t).reshape(3)[2])
