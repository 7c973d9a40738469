"""The start pose of a sequence that states none, from its first range-bearing rows to known landmarks.

A sequence without an initial pose or ground truth starts "at the origin" (``Sequence.start_pose``), which is no
pose in the frame of a surveyed map: a localizer started there with ``initial_cov`` refuses every landmark until its
lock-out guard forces them in (MRCLAM Dataset 1: metres of error for the first 100 s). The start pose s = (t, θ) at
``sequence.t0`` is instead fitted to the first observations:

    r_i, P_i    the dead-reckoned pose (3,) at row i's stamp in the start frame and its covariance (3, 3): the
                localizer's own prediction from (0, 0) with P = 0
    p_i = g(r_i, z_i)                  (2,)   the landmark the row sees, in the start frame (models.inverse_observe)
    C_i = G_x P_i G_xᵀ + G_z R G_zᵀ    (2, 2) its covariance (models.inverse_observation_jacobians; R = R_landmark)
    e_i(s) = m_i − (t + R(θ) p_i)      (2,)   against the surveyed position m_i, covariance R(θ) C_i R(θ)ᵀ
    ŝ = argmin Σ e_iᵀ (R C_i Rᵀ)⁻¹ e_i         2-D Procrustes start, then Gauss-Newton
    P_s = (Σ J_iᵀ (R C_i Rᵀ)⁻¹ J_i)⁻¹  (3, 3), J_i = ∂(s ⊕ p_i)/∂s = [[1, 0, −(R p_i)_y], [0, 1, (R p_i)_x]]

Rows are taken in time order until they see :data:`MIN_LANDMARKS` different landmarks and every row's
d²_i = e_iᵀ (R C_i Rᵀ)⁻¹ e_i is within the landmark gate (two landmarks fix the pose, the third checks it). A set that
fails the check is not fitted again until a further landmark is seen; then the landmark whose removal leaves the
smallest Σ d² is left out for good (``dropped``): one wrong surveyed position or misread id cannot pick the start.
The rows are correlated through the shared dead reckoning, which the fit ignores (P_s is optimistic by that), and the
filter then applies them again: over the fit's window their information is counted twice. Both affect the first
seconds only; the pose is what the rest of the run needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slamarena.datasets.geometry import rotation, wrap_angle
from slamarena.datasets.sequence import LandmarkMap
from slamarena.estimators.models import inverse_observation_jacobians, inverse_observe

__all__ = ["StartSearch", "MIN_LANDMARKS", "fit_start"]

#: different landmarks the start pose is fitted to: two determine it, the third checks it
MIN_LANDMARKS = 3
_GAUSS_NEWTON = 10


def fit_start(p: np.ndarray, C: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pose s (3,) with s ⊕ p_i ≈ m_i weighted by C_i (module docstring), its covariance (3, 3) and d²_i (N,).

    ``p``, ``m`` (N, 2), ``C`` (N, 2, 2); at least two different points."""
    pc, mc = p - p.mean(axis=0), m - m.mean(axis=0)
    H = pc.T @ mc
    theta = np.arctan2(H[0, 1] - H[1, 0], H[0, 0] + H[1, 1])
    s = np.r_[m.mean(axis=0) - rotation(theta) @ p.mean(axis=0), theta]
    for _ in range(_GAUSS_NEWTON):
        Rot = rotation(s[2])
        q = p @ Rot.T  # R p_i
        e = m - (s[:2] + q)
        W = np.linalg.inv(Rot @ C @ Rot.T)  # (N, 2, 2)
        J = np.zeros((len(p), 2, 3))
        J[:, 0, 0] = J[:, 1, 1] = 1.0
        J[:, 0, 2], J[:, 1, 2] = -q[:, 1], q[:, 0]
        info = np.einsum("nki,nkl,nlj->ij", J, W, J)
        step = np.linalg.solve(info, np.einsum("nki,nkl,nl->i", J, W, e))
        s = s + step
        s[2] = wrap_angle(s[2])
        if np.abs(step).max() < 1e-10:
            break
    Rot = rotation(s[2])
    e = m - (s[:2] + p @ Rot.T)
    d2 = np.einsum("ni,nij,nj->n", e, np.linalg.inv(Rot @ C @ Rot.T), e)
    return s, np.linalg.inv(info), d2


@dataclass
class StartSearch:
    """Rows added in time order until the start pose is fitted and checked (module docstring)."""

    landmarks: LandmarkMap
    R: np.ndarray  # (2, 2) range-bearing covariance
    gate: float  # χ²₂ bound on every row's d²
    ids: list[int] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    covs: list[np.ndarray] = field(default_factory=list)
    dropped: list[int] = field(default_factory=list)
    _failed_with: int = 0  # the number of landmarks of the last set that failed the check

    def add(self, x: np.ndarray, P: np.ndarray, ids: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Rows ``z`` (M, 2) of landmarks ``ids`` (M,) seen from the dead-reckoned pose ``x`` (3,) of covariance ``P``;
        the start pose and its covariance once they are determined and checked, else None."""
        keep = np.isin(ids, self.landmarks.ids) & ~np.isin(ids, self.dropped) & np.all(np.isfinite(z), axis=1)
        z = z[keep]
        Gx, Gz = inverse_observation_jacobians(np.broadcast_to(x, (len(z), 3)), z)
        self.ids.extend(int(i) for i in ids[keep])
        self.points.extend(inverse_observe(np.broadcast_to(x, (len(z), 3)), z))
        self.covs.extend(Gx @ P @ Gx.transpose(0, 2, 1) + Gz @ self.R @ Gz.transpose(0, 2, 1))
        return self._check() if keep.any() else None

    def _check(self) -> tuple[np.ndarray, np.ndarray] | None:
        seen = set(self.ids)
        if len(seen) < MIN_LANDMARKS or len(seen) == self._failed_with:
            return None
        s, cov, d2 = self._fit()
        if np.all(d2 <= self.gate):
            return s, cov
        if len(seen) > MIN_LANDMARKS:
            self._drop_worst(seen)
            return self._check()
        self._failed_with = len(seen)
        return None

    def _fit(self, without: int | None = None):
        ids = np.array(self.ids)
        rows = ids != without
        m = np.array([self.landmarks.position(i) for i in ids[rows]])
        return fit_start(np.array(self.points)[rows], np.array(self.covs)[rows], m)

    def _drop_worst(self, seen: set[int]) -> None:
        worst = min(seen, key=lambda j: self._fit(without=j)[2].sum())
        rows = [k for k, i in enumerate(self.ids) if i != worst]
        self.ids = [self.ids[k] for k in rows]
        self.points = [self.points[k] for k in rows]
        self.covs = [self.covs[k] for k in rows]
        self.dropped.append(worst)
        self._failed_with = 0
