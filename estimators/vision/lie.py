"""SO(3) and SE(3) on numpy arrays: the skew matrix, exponential and logarithm maps.

A pose is the pair ``(R, t)`` of ``T_cam←world`` (x_c = R X + t), R (3, 3), t (3,). The perturbation used by every
Gauss-Newton step of the camera path is on the left: ``T ← exp(ξ^) T`` with ξ = (ρ, φ) (6,), ρ the translation and
φ the rotation part, so that x_c ↦ x_c + ρ + φ × x_c to first order::

    [φ]× = [[0, −φz, φy], [φz, 0, −φx], [−φy, φx, 0]]
    exp(φ) = I + sin θ/θ [φ]× + (1 − cos θ)/θ² [φ]×²,          θ = ||φ||            (Rodrigues)
    exp(ξ) = (exp(φ), V ρ),  V = I + (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×²
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["skew", "so3_exp", "so3_log", "se3_exp", "se3_exp_kernel", "rotation_angle"]


def skew(v: np.ndarray) -> np.ndarray:
    """[v]× (..., 3, 3) of v (..., 3): [v]× w = v × w."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    return out - np.swapaxes(out, -1, -2)


def _coefficients(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³ with their Taylor series near θ = 0."""
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    a = np.where(small, 1 - theta**2 / 6, np.sin(t) / t)
    b = np.where(small, 0.5 - theta**2 / 24, (1 - np.cos(t)) / t**2)
    c = np.where(small, 1 / 6 - theta**2 / 120, (t - np.sin(t)) / t**3)
    return a, b, c


def so3_exp(phi: np.ndarray) -> np.ndarray:
    """exp([φ]×) (..., 3, 3) of φ (..., 3)."""
    phi = np.asarray(phi, dtype=float)
    a, b, _ = _coefficients(np.linalg.norm(phi, axis=-1))
    W = skew(phi)
    return np.eye(3) + a[..., None, None] * W + b[..., None, None] * W @ W


def so3_log(R: np.ndarray) -> np.ndarray:
    """φ (3,) with exp([φ]×) = R, ||φ|| ≤ π (the axis from the symmetric part near θ = π)."""
    R = np.asarray(R, dtype=float)
    cos = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    theta = float(np.arccos(cos))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2
    if theta < 1e-6:
        return w
    if np.pi - theta < 1e-4:
        B = (R + np.eye(3)) / 2  # = k kᵀ at θ = π
        k = B[np.argmax(np.diag(B))]
        k = k / np.linalg.norm(k)
        return theta * (k if k @ w >= 0 else -k)
    return theta / np.sin(theta) * w


def se3_exp(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """exp(ξ^) as (R, t) for ξ = (ρ, φ) (6,)."""
    xi = np.asarray(xi, dtype=float)
    rho, phi = xi[:3], xi[3:]
    _, b, c = _coefficients(np.linalg.norm(phi))
    W = skew(phi)
    V = np.eye(3) + b * W + c * W @ W
    return so3_exp(phi), V @ rho


@numba.njit(cache=True)
def se3_exp_kernel(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`se3_exp` of one ξ (6,) compiled, for the loops of :mod:`.pnp` (the same Rodrigues formulas)."""
    phi = xi[3:]
    theta = np.sqrt(np.sum(phi**2))
    if theta < 1e-4:
        a, b, c = 1 - theta**2 / 6, 0.5 - theta**2 / 24, 1 / 6 - theta**2 / 120
    else:
        a, b, c = np.sin(theta) / theta, (1 - np.cos(theta)) / theta**2, (theta - np.sin(theta)) / theta**3
    W = np.array([[0.0, -phi[2], phi[1]], [phi[2], 0.0, -phi[0]], [-phi[1], phi[0], 0.0]])
    W2 = W @ W
    I = np.eye(3)
    return I + a * W + b * W2, (I + b * W + c * W2) @ xi[:3]


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """The angle [rad] of rotations R (..., 3, 3), in [0, π]."""
    return np.arccos(np.clip((np.trace(R, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0))
