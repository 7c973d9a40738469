"""The pinhole projection, its reprojection residual and the residual's Jacobians.

A camera pose ``T = (R, t)`` is ``T_cam←world``; a world point X (3,) is seen at ::

    x_c = R X + t = (x, y, z)                                       camera coordinates
    π(x_c) = (fx x/z + cx,  fy y/z + cy)                            pixel (K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    r = π(R X + t) − u                                              residual (2,), u the observed pixel

Jacobians (left perturbation ``T ← exp(ξ^) T``, ξ = (ρ, φ), :mod:`.lie`: δx_c = ρ − [x_c]× φ)::

    ∂π/∂x_c = [[fx/z, 0, −fx x/z²], [0, fy/z, −fy y/z²]]           (2, 3)
    ∂r/∂ξ   = ∂π/∂x_c [I₃ | −[x_c]×]                               (2, 6)
    ∂r/∂X   = ∂π/∂x_c R                                             (2, 3)

All functions are vectorised over n points (leading axis n).
"""

from __future__ import annotations

import numpy as np

from .lie import skew

__all__ = ["project", "residuals", "jacobians", "normalise", "distort_radial_pixels", "undistort_radial_pixels"]


def project(K: np.ndarray, R: np.ndarray, t: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Pixels (n, 2) of world points X (n, 3)."""
    xc = np.asarray(X, float) @ np.asarray(R).T + np.asarray(t).reshape(3)
    return xc[:, :2] / xc[:, 2:] * np.diag(K)[:2] + K[:2, 2]


def residuals(K: np.ndarray, R: np.ndarray, t: np.ndarray, X: np.ndarray, u: np.ndarray) -> np.ndarray:
    """r = π(R X + t) − u (n, 2)."""
    return project(K, R, t, X) - np.asarray(u, float)


def jacobians(K: np.ndarray, R: np.ndarray, t: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(∂r/∂ξ (n, 2, 6), ∂r/∂X (n, 2, 3)) at the world points X (n, 3)."""
    xc = np.asarray(X, float) @ np.asarray(R).T + np.asarray(t).reshape(3)
    x, y, z = xc[:, 0], xc[:, 1], xc[:, 2]
    fx, fy = K[0, 0], K[1, 1]
    dpi = np.zeros((len(xc), 2, 3))
    dpi[:, 0, 0], dpi[:, 0, 2] = fx / z, -fx * x / z**2
    dpi[:, 1, 1], dpi[:, 1, 2] = fy / z, -fy * y / z**2
    dxi = np.concatenate([np.broadcast_to(np.eye(3), (len(xc), 3, 3)), -skew(xc)], axis=2)  # (n, 3, 6)
    return dpi @ dxi, dpi @ np.asarray(R)


def normalise(K: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Normalised image coordinates (n, 2) of pixels u (n, 2): ((u − cx)/fx, (v − cy)/fy) (zero skew)."""
    return (np.asarray(u, float) - K[:2, 2]) / np.diag(K)[:2]


def distort_radial_pixels(K: np.ndarray, k: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Distorted pixels (n, 2) of undistorted ones: c + (u − c)(1 + k1 r² + k2 r⁴), r² = ||u − c||² [px²]."""
    d = np.asarray(u, float) - K[:2, 2]
    r2 = (d**2).sum(1, keepdims=True)
    return K[:2, 2] + d * (1 + k[0] * r2 + k[1] * r2**2)


def undistort_radial_pixels(K: np.ndarray, k: np.ndarray, u: np.ndarray, iterations: int = 20) -> np.ndarray:
    """The inverse of :func:`distort_radial_pixels` by fixed-point iteration ``p ← (u − c)/(1 + k1 r(p)² + k2 r(p)⁴)``."""
    d = np.asarray(u, float) - K[:2, 2]
    p = d.copy()
    for _ in range(iterations):
        r2 = (p**2).sum(1, keepdims=True)
        p = d / (1 + k[0] * r2 + k[1] * r2**2)
    return K[:2, 2] + p
