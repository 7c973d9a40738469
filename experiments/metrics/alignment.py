"""Alignment of an estimated trajectory to the reference: none, SE(2) or Sim(2) (Umeyama 1991, in 2D).

Given matched positions ``p_i`` (estimate) and ``q_i`` (reference), Umeyama's closed form finds
``(s, R, t)`` minimising ``Σ ||q_i − (s R p_i + t)||²``::

    μ_p, μ_q = means;  σ_p² = mean ||p_i − μ_p||²;  Σ = mean (q_i − μ_q)(p_i − μ_p)ᵀ  (2, 2)
    Σ = U D Vᵀ (SVD);  S = diag(1, det U · det V)
    R = U S Vᵀ;  s = tr(D S) / σ_p²  (Sim(2); s = 1 for SE(2));  t = μ_q − s R μ_p

A pose ``(x, y, θ)`` maps to ``(s R [x, y] + t, θ + angle(R))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slamarena.datasets.geometry import rotation, wrap_angle

__all__ = ["ALIGNMENTS", "Alignment", "umeyama", "fit_alignment"]

ALIGNMENTS = ("none", "se2", "sim2")


@dataclass(frozen=True)
class Alignment:
    """x ↦ s R(angle) x + t."""

    angle: float = 0.0
    translation: tuple[float, float] = (0.0, 0.0)
    scale: float = 1.0

    def points(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return self.scale * xy @ rotation(self.angle).T + np.asarray(self.translation)

    def poses(self, poses: np.ndarray) -> np.ndarray:
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        return np.column_stack([self.points(poses[:, :2]), wrap_angle(poses[:, 2] + self.angle)])

    def as_dict(self) -> dict:
        return {"angle": self.angle, "tx": self.translation[0], "ty": self.translation[1], "scale": self.scale}


def umeyama(p: np.ndarray, q: np.ndarray, with_scale: bool) -> Alignment:
    """Least-squares similarity (or rigid, ``with_scale=False``) transform taking points p onto q."""
    p = np.asarray(p, dtype=float).reshape(-1, 2)
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    if p.shape != q.shape or len(p) == 0:
        raise ValueError(f"umeyama needs matched, non-empty point sets; got {p.shape} and {q.shape}")
    mu_p, mu_q = p.mean(axis=0), q.mean(axis=0)
    if len(p) == 1:
        return Alignment(0.0, tuple(mu_q - mu_p), 1.0)
    dp, dq = p - mu_p, q - mu_q
    Sigma = dq.T @ dp / len(p)
    U, D, Vt = np.linalg.svd(Sigma)
    S = np.diag([1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0])
    R = U @ S @ Vt
    var_p = float(np.mean(np.sum(dp**2, axis=1)))
    s = float(np.trace(np.diag(D) @ S) / var_p) if with_scale and var_p > 0 else 1.0
    t = mu_q - s * R @ mu_p
    return Alignment(float(np.arctan2(R[1, 0], R[0, 0])), (float(t[0]), float(t[1])), s)


def fit_alignment(p: np.ndarray, q: np.ndarray, mode: str) -> Alignment:
    """The alignment of ``mode`` (``none``, ``se2``, ``sim2``) taking positions p onto q."""
    if mode not in ALIGNMENTS:
        raise ValueError(f"alignment must be one of {ALIGNMENTS}, got {mode!r}")
    if mode == "none":
        return Alignment()
    return umeyama(p, q, with_scale=mode == "sim2")
