"""ICP baselines through kiss-icp and Open3D, with 2D scans lifted to z = 0 points.

Both match the scan (robot frame) against a reference point set (world frame) from a
guess and return the SE(2) part of the 3D result: ``(t_x, t_y, atan2(R₁₀, R₀₀))``.

kiss-icp (Vizzo et al. 2023): the reference goes into kiss-icp's ``VoxelHashMap`` and the scan
is aligned with its ``Registration.align_points_to_map`` (point-to-point ICP with a
Geman-McClure kernel). Its default voxel size, ``max_range / 100``, is 0.8 m for an 80 m
laser — too coarse for indoor 2D scans — so ``voxel_size`` is set for 2D scales (0.1 m);
the correspondence gate and kernel are fixed (``max_correspondence``, ``max_correspondence / 3``)
instead of kiss's adaptive threshold, because a matcher receives an external guess.

Open3D: ``registration_icp`` point-to-point or point-to-plane, or
``registration_generalized_icp``. Normals and covariances of z = 0 points estimated by
Open3D in 3D are degenerate (every neighbourhood is the z = 0 plane, so every normal is
±z), so they are computed here in 2D from the k nearest neighbours: normal = the
eigenvector of the smallest eigenvalue of the 2 × 2 neighbourhood covariance, lifted as
``(n_x, n_y, 0)``; GICP covariances ``R diag(ε, 1) Rᵀ`` in the plane (the plane-to-plane
model of Segal et al. 2009) and 1 along z.

Covariance (both): the Gauss-Newton approximation of 2D point-to-point ICP at the result,
``σ̂² (Σ J_iᵀ J_i)⁻¹`` with ``J_i = [I₂, R'(θ) s_i]`` over inlier nearest neighbours and
``σ̂²`` their mean squared residual. Score: the inlier fraction.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import NonNegativeFloat, PositiveFloat, PositiveInt

from slamarena.params import Field, Params

from . import MatchResult

__all__ = ["KissICPMatcher", "KissICPMatcherParams", "Open3DICPMatcher", "Open3DICPMatcherParams", "normals_2d"]


def _se2_to_matrix(pose) -> np.ndarray:
    c, s = np.cos(pose[2]), np.sin(pose[2])
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = pose[:2]
    return T


def _matrix_to_se2(T) -> np.ndarray:
    return np.array([T[0, 3], T[1, 3], np.arctan2(T[1, 0], T[0, 0])])


def _lift(xy) -> np.ndarray:
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    return np.column_stack([xy, np.zeros(len(xy))])


def normals_2d(xy: np.ndarray, k: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (N, 2) and the 2 × 2 neighbourhood covariances (N, 2, 2) of 2D points."""
    from scipy.spatial import cKDTree

    xy = np.asarray(xy, dtype=float)
    k = min(k, len(xy))
    _, idx = cKDTree(xy).query(xy, k=k)
    nb = xy[idx] - xy[idx].mean(axis=1, keepdims=True)
    C = np.einsum("nki,nkj->nij", nb, nb) / max(k - 1, 1)
    _, V = np.linalg.eigh(C)
    return V[:, :, 0], C


def _laplace_and_score(reference, points, pose, gate) -> tuple[np.ndarray, float]:
    from scipy.spatial import cKDTree

    c, s = np.cos(pose[2]), np.sin(pose[2])
    world = points @ np.array([[c, s], [-s, c]]) + pose[:2]
    d, j = cKDTree(reference).query(world, distance_upper_bound=gate)
    inl = np.isfinite(d)
    n = int(inl.sum())
    if n <= 3:
        return np.diag([np.inf] * 3), n / max(len(points), 1)
    p = points[inl]
    J = np.zeros((n, 2, 3))
    J[:, 0, 0] = J[:, 1, 1] = 1.0
    J[:, 0, 2] = -s * p[:, 0] - c * p[:, 1]
    J[:, 1, 2] = c * p[:, 0] - s * p[:, 1]
    H = np.einsum("nki,nkj->ij", J, J)
    sigma2 = float(np.sum(d[inl] ** 2)) / (2 * n - 3)
    return sigma2 * np.linalg.inv(H), n / len(points)


class KissICPMatcherParams(Params):
    """Parameters of :class:`KissICPMatcher`."""

    voxel_size: PositiveFloat = Field(
        0.1, description="voxel side of kiss-icp's VoxelHashMap holding the reference [m]"
    )
    max_points_per_voxel: PositiveInt = Field(20, description="most reference points kept per voxel")
    max_correspondence: PositiveFloat = Field(
        0.5, description="correspondence gate [m]; the Geman-McClure kernel is a third of it"
    )
    max_iterations: PositiveInt = Field(500, description="most ICP iterations")
    convergence: NonNegativeFloat = Field(
        1e-4, description="ICP stops when the norm of an update (se(3) twist [m, rad]) is below this"
    )


class KissICPMatcher:
    """kiss-icp point-to-map registration of a 2D scan (module docstring, :class:`KissICPMatcherParams`)."""

    kind = "points"
    takes_odometry = False
    Params = KissICPMatcherParams

    def __init__(self, params: KissICPMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self._registration = None

    def match(self, reference, points, guess) -> MatchResult:
        from kiss_icp.mapping import VoxelHashMap
        from kiss_icp.registration import Registration

        p = self.params
        if self._registration is None:
            self._registration = Registration(
                max_num_iterations=p.max_iterations, convergence_criterion=p.convergence, max_num_threads=1
            )
        reference = np.asarray(reference, dtype=float).reshape(-1, 2)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        voxel_map = VoxelHashMap(voxel_size=p.voxel_size, max_distance=1e6, max_points_per_voxel=p.max_points_per_voxel)
        voxel_map.add_points(_lift(reference))
        T = self._registration.align_points_to_map(
            points=_lift(points),
            voxel_map=voxel_map,
            initial_guess=_se2_to_matrix(np.asarray(guess, dtype=float)),
            max_correspondance_distance=p.max_correspondence,
            kernel=p.max_correspondence / 3.0,
        )
        pose = _matrix_to_se2(np.asarray(T))
        cov, score = _laplace_and_score(reference, points, pose, p.max_correspondence)
        return MatchResult(pose=pose, cov=cov, score=score)


class Open3DICPMatcherParams(Params):
    """Parameters of :class:`Open3DICPMatcher`."""

    method: Literal["point_to_point", "point_to_plane", "generalized"] = Field(
        "point_to_plane", description="Open3D registration: point-to-point or point-to-plane ICP, or generalized ICP"
    )
    max_correspondence: PositiveFloat = Field(0.5, description="correspondence gate [m]")
    max_iterations: PositiveInt = Field(50, description="most ICP iterations")
    neighbours: int = Field(8, ge=3, description="k nearest neighbours of the 2D normals and covariances")
    epsilon: PositiveFloat = Field(
        1e-3, description="GICP's variance along the normal relative to the tangent's, ε of R diag(ε, 1) Rᵀ"
    )


class Open3DICPMatcher:
    """Open3D ICP: ``method`` point_to_point, point_to_plane or generalized (module docstring, :class:`Open3DICPMatcherParams`)."""

    kind = "points"
    takes_odometry = False
    Params = Open3DICPMatcherParams

    def __init__(self, params: Open3DICPMatcherParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)

    def _cloud(self, xy, with_normals: bool, with_covariances: bool):
        import open3d as o3d

        pc = o3d.geometry.PointCloud()
        pc.points = o3d.utility.Vector3dVector(_lift(xy))
        if with_normals or with_covariances:
            n, _ = normals_2d(xy, self.params.neighbours)
            if with_normals:
                pc.normals = o3d.utility.Vector3dVector(_lift(n))
            if with_covariances:
                t = np.column_stack([-n[:, 1], n[:, 0]])
                C = np.zeros((len(n), 3, 3))
                C[:, :2, :2] = self.params.epsilon * np.einsum("ni,nj->nij", n, n) + np.einsum("ni,nj->nij", t, t)
                C[:, 2, 2] = 1.0
                pc.covariances = o3d.utility.Matrix3dVector(C)
        return pc

    def match(self, reference, points, guess) -> MatchResult:
        import open3d as o3d

        reg = o3d.pipelines.registration
        p = self.params
        reference = np.asarray(reference, dtype=float).reshape(-1, 2)
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        gicp = p.method == "generalized"
        source = self._cloud(points, False, gicp)
        target = self._cloud(reference, p.method == "point_to_plane", gicp)
        criteria = reg.ICPConvergenceCriteria(max_iteration=p.max_iterations)
        init = _se2_to_matrix(np.asarray(guess, dtype=float))
        if gicp:
            out = reg.registration_generalized_icp(
                source,
                target,
                p.max_correspondence,
                init,
                reg.TransformationEstimationForGeneralizedICP(p.epsilon),
                criteria,
            )
        else:
            estimation = (
                reg.TransformationEstimationPointToPlane()
                if p.method == "point_to_plane"
                else reg.TransformationEstimationPointToPoint()
            )
            out = reg.registration_icp(source, target, p.max_correspondence, init, estimation, criteria)
        pose = _matrix_to_se2(np.asarray(out.transformation))
        cov, score = _laplace_and_score(reference, points, pose, p.max_correspondence)
        return MatchResult(
            pose=pose, cov=cov, score=score, info={"fitness": float(out.fitness), "inlier_rmse": float(out.inlier_rmse)}
        )
