"""Point-to-line ICP of one 2D scan onto another (Censi 2008's error metric, solved by Gauss-Newton).

Reference: world points q_j (M, 2) with unit normals n_j (M, 2) (the eigenvector of the smallest eigenvalue of the
2 × 2 covariance of each point's k nearest neighbours, :func:`~slamarena.mapping.scan_matching.icp.normals_2d`). Scan:
end points s_i (N, 2) in the robot frame. Pose ξ = (t_x, t_y, ψ); S_i(ξ) = R(ψ) s_i + t. Each iteration pairs S_i
with its nearest reference point j(i) when it lies within ``max_correspondence`` and minimises, with the pairs fixed,

    E(ξ) = Σ_i r_i²,   r_i = n_{j(i)}ᵀ (S_i(ξ) − q_{j(i)})                       (scalar per pair)

by one Gauss-Newton step (the point-to-line residual is the distance to the reference's local line, so a scan
sliding along a wall costs nothing: that direction is left to the other walls):

    J_i = n_{j(i)}ᵀ [I₂, R'(ψ) s_i]   (1, 3),   R'(ψ) s = (−sinψ s_x − cosψ s_y, cosψ s_x − sinψ s_y)
    Δξ = −(Σ J_iᵀ J_i)⁻¹ Σ J_iᵀ r_i

until the step is below (``tol_translation``, ``tol_rotation``) or after ``max_iterations``. Covariance at the
result: the Laplace approximation σ̂² (Σ J_iᵀ J_i)⁻¹, σ̂² = Σ r_i² / (n − 3) (a corridor, whose walls all share one
normal, leaves the direction along it with a large variance). Score: the fraction of scan points paired.

:meth:`PointToLineICPMatcher.prepare` builds a reference's k-d tree and normals once, for a scan matched against
several others (laser SLAM's local refinement pairs each scan with its predecessors).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt

from slamarena.params import Field, Params

from . import MatchResult
from .icp import normals_2d

__all__ = ["PointToLineICPMatcher", "PointToLineICPMatcherParams", "PreparedReference", "residuals_and_jacobian"]


class PointToLineICPMatcherParams(Params):
    """Parameters of :class:`PointToLineICPMatcher`."""

    max_correspondence: PositiveFloat = Field(0.15, description="a scan point is paired with its nearest reference point only within this distance [m]")
    max_iterations: PositiveInt = Field(30, description="most ICP iterations (each: new pairs, one Gauss-Newton step)")
    tol_translation: NonNegativeFloat = Field(1e-5, description="ICP stops when a step moves less than this [m] (and turns less than tol_rotation)")
    tol_rotation: NonNegativeFloat = Field(1e-5, description="ICP stops when a step turns less than this [rad] (and moves less than tol_translation)")
    neighbours: int = Field(8, ge=3, description="k nearest neighbours of a reference point's normal")


@dataclass
class PreparedReference:
    """A reference point set (M, 2), its unit normals (M, 2) and its k-d tree."""

    points: np.ndarray
    normals: np.ndarray
    tree: object


def residuals_and_jacobian(pose: np.ndarray, points: np.ndarray, q: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """r_i = n_iᵀ(R(ψ) s_i + t − q_i) (N,) and its Jacobian J (N, 3) with respect to ξ = (t_x, t_y, ψ) (module docstring)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    x, y = points[:, 0], points[:, 1]
    wx, wy = c * x - s * y + pose[0], s * x + c * y + pose[1]
    r = n[:, 0] * (wx - q[:, 0]) + n[:, 1] * (wy - q[:, 1])
    J = np.column_stack([n[:, 0], n[:, 1], n[:, 0] * (-s * x - c * y) + n[:, 1] * (c * x - s * y)])
    return r, J


class PointToLineICPMatcher:
    """Point-to-line ICP (module docstring, :class:`PointToLineICPMatcherParams`)."""

    kind = "points"
    Params = PointToLineICPMatcherParams

    def __init__(self, params: PointToLineICPMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def prepare(self, reference: np.ndarray) -> PreparedReference:
        """The reference's normals and k-d tree, for matching several scans against it."""
        from scipy.spatial import cKDTree

        reference = np.asarray(reference, dtype=float).reshape(-1, 2)
        normals, _ = normals_2d(reference, self.params.neighbours)
        return PreparedReference(reference, normals, cKDTree(reference))

    def match(self, reference, points, guess) -> MatchResult:
        """Scan ``points`` (N, 2, robot frame) onto ``reference`` (world points (M, 2) or a :class:`PreparedReference`) from ``guess``."""
        p = self.params
        ref = reference if isinstance(reference, PreparedReference) else self.prepare(reference)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        pose = np.asarray(guess, dtype=float).copy()
        it = 0
        for it in range(1, p.max_iterations + 1):
            r, J, paired = self._pairs(ref, points, pose)
            if paired.sum() < 3:
                return MatchResult(pose=pose, cov=np.diag([np.inf] * 3), score=0.0, iterations=it)
            H = J.T @ J
            try:
                step = -np.linalg.solve(H, J.T @ r)
            except np.linalg.LinAlgError:
                return MatchResult(pose=pose, cov=np.diag([np.inf] * 3), score=0.0, iterations=it)
            pose = pose + step
            if np.hypot(step[0], step[1]) < p.tol_translation and abs(step[2]) < p.tol_rotation:
                break
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        r, J, paired = self._pairs(ref, points, pose)
        n = int(paired.sum())
        H = J.T @ J
        eig = np.linalg.eigvalsh(H) if n > 3 else np.zeros(3)
        cov = float(r @ r) / (n - 3) * np.linalg.inv(H) if eig[0] * 1e12 >= eig[-1] > 0 else np.diag([np.inf] * 3)
        return MatchResult(pose=pose, cov=cov, score=n / max(len(points), 1), iterations=it, info={"paired": n})

    def _pairs(self, ref: PreparedReference, points: np.ndarray, pose: np.ndarray):
        """Residuals and Jacobian of the scan points paired at ``pose``, and the mask of the paired points."""
        c, s = np.cos(pose[2]), np.sin(pose[2])
        world = points @ np.array([[c, s], [-s, c]]) + pose[:2]
        d, j = ref.tree.query(world, distance_upper_bound=self.params.max_correspondence)
        paired = np.isfinite(d)
        r, J = residuals_and_jacobian(pose, points[paired], ref.points[j[paired]], ref.normals[j[paired]])
        return r, J, paired
