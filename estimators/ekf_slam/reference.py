"""The literal, dense EKF-SLAM of the notes — the test oracle of :class:`EKFSLAM`.

It writes the notes' equations as they stand (matrix-dimensions reference, lecture notes,
technical notes), with every matrix full-size, but with the errata corrected
(``research/method/ekf_slam.md``): covariance propagated as ``G P Gᵀ`` (not ``Gᵀ P G``), the
observation noise R (not the motion-noise block ``Cx[0:2, 0:2]``) in S, the predicted
covariance (not its inverse) in the gain, the bearing innovation and the yaw wrapped, the
exact arc model with the corrected sign of its y row. Known data association only. Cost
O(N³) per step: this is the oracle, not an estimator to run at scale.

Predict::

    Fx = [I₃ 0 … 0] (3×N),  jF = ∂f/∂x_r − I₃ (3×3),  G = I_N + Fxᵀ jF Fx (N×N)
    xEst[0:3] = f(xEst[0:3], u, dt)
    PEst = G PEst Gᵀ + Fxᵀ Q Fx ,   Q = V M Vᵀ or Cx·dt

Update, one observation of landmark i (batch: rows of H and y stacked, R → I_m ⊗ R)::

    F = [F1; F2] (5×N) selecting robot and landmark i,  H = [H_x H_m] F (2×N)
    y = z − h(xEst) (bearing wrapped),  S = H PEst Hᵀ + R,  K = PEst Hᵀ inv(S)
    xEst = xEst + K y (yaw wrapped),  PEst = (I − K H) PEst
    Joseph: PEst = (I − K H) PEst (I − K H)ᵀ + K R Kᵀ

New landmark (inverse observation model, augmentation written densely)::

    Gm = G_x Fx (2×N)
    PAug = [[PEst, PEst Gmᵀ], [Gm PEst, Gm PEst Gmᵀ + G_z R G_zᵀ]]       init="jacobian"
    PAug = [[PEst, 0], [0, initP]]                                          init="initP"
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.geometry import wrap_angle

from ..models import MOTION_MODELS, inverse_observation_jacobians, inverse_observe, observation_jacobians, observe
from .filter import CovarianceUpdate, LandmarkInit, MotionNoise, UpdateForm

__all__ = ["ReferenceEKFSLAM"]


class ReferenceEKFSLAM:
    """Dense EKF-SLAM; parameters as :class:`EKFSLAM` (matrices given explicitly)."""

    def __init__(
        self,
        M,
        R,
        *,
        motion_model: str = "arc",
        motion_noise: MotionNoise = MotionNoise.CONTROL,
        Cx=None,
        covariance_update: CovarianceUpdate = CovarianceUpdate.STANDARD,
        init: LandmarkInit = LandmarkInit.JACOBIAN,
        init_cov: float = 1.0,
        update: UpdateForm = UpdateForm.SEQUENTIAL,
        initial_pose=(0.0, 0.0, 0.0),
    ):
        self.model = MOTION_MODELS[motion_model]
        self.M, self.R = np.asarray(M, dtype=float), np.asarray(R, dtype=float)
        self.Cx = None if Cx is None else np.asarray(Cx, dtype=float)
        self.motion_noise, self.covariance_update = motion_noise, covariance_update
        self.init, self.init_cov, self.batch = init, init_cov, update == UpdateForm.BATCH
        self.xEst = np.asarray(initial_pose, dtype=float).copy()
        self.PEst = np.zeros((3, 3))
        self.ids: list[int] = []

    def Fx(self) -> np.ndarray:
        N = self.xEst.size
        return np.hstack([np.eye(3), np.zeros((3, N - 3))])

    def predict(self, u, dt: float) -> None:
        v, w = u
        N = self.xEst.size
        Fx = self.Fx()
        G3, V = self.model.jacobians(self.xEst[:3], v, w, dt)
        jF = G3 - np.eye(3)
        G = np.eye(N) + Fx.T @ jF @ Fx
        Q = V @ self.M @ V.T if self.motion_noise == MotionNoise.CONTROL else self.Cx * dt
        self.xEst[:3] = self.model.predict(self.xEst[:3], v, w, dt)
        self.PEst = G @ self.PEst @ G.T + Fx.T @ Q @ Fx

    def update(self, z) -> None:
        """Rows in order: update with a known landmark or augment with a new one.

        ``update="batch"``: all rows of already known landmarks first, as one stacked update,
        then the remaining rows in order.
        """
        z = np.asarray(z, dtype=float).reshape(-1, 3)
        if self.batch:
            known = np.array([int(i) in self.ids for i in z[:, 2]], dtype=bool)
            if known.any():
                self._correct([self.ids.index(int(i)) for i in z[known, 2]], z[known, :2])
            z = z[~known]
        for r, b, landmark_id in z:
            landmark_id = int(landmark_id)
            if landmark_id in self.ids:
                self._correct([self.ids.index(landmark_id)], np.array([[r, b]]))
            else:
                self._augment(np.array([r, b]))
                self.ids.append(landmark_id)

    def _correct(self, landmarks: list[int], z: np.ndarray) -> None:
        """One update with the observations z (m, 2) of the landmarks (m,): H stacked (2m×N)."""
        N = self.xEst.size
        H_rows, zp = [], []
        for i in landmarks:
            lm = self.xEst[3 + 2 * i : 5 + 2 * i]
            F1 = np.hstack([np.eye(3), np.zeros((3, N - 3))])
            F2 = np.zeros((2, N))
            F2[:, 3 + 2 * i : 5 + 2 * i] = np.eye(2)
            F = np.vstack([F1, F2])
            Hx, Hm = observation_jacobians(self.xEst[:3], lm)
            H_rows.append(np.hstack([Hx, Hm]) @ F)
            zp.append(observe(self.xEst[:3], lm))
        H = np.vstack(H_rows)
        y = z - np.array(zp)
        y[:, 1] = wrap_angle(y[:, 1])
        y = y.ravel()
        Q = np.kron(np.eye(len(landmarks)), self.R)
        S = H @ self.PEst @ H.T + Q
        K = self.PEst @ H.T @ np.linalg.inv(S)
        self.xEst = self.xEst + K @ y
        self.xEst[2] = wrap_angle(self.xEst[2])
        I_KH = np.eye(N) - K @ H
        if self.covariance_update == CovarianceUpdate.JOSEPH:
            self.PEst = I_KH @ self.PEst @ I_KH.T + K @ Q @ K.T
        else:
            self.PEst = I_KH @ self.PEst

    def _augment(self, z: np.ndarray) -> None:
        N = self.xEst.size
        m = inverse_observe(self.xEst[:3], z)
        Gx, Gz = inverse_observation_jacobians(self.xEst[:3], z)
        Gm = Gx @ self.Fx()
        if self.init == LandmarkInit.JACOBIAN:
            cross = Gm @ self.PEst
            corner = Gm @ self.PEst @ Gm.T + Gz @ self.R @ Gz.T
        else:
            cross = np.zeros((2, N))
            corner = self.init_cov * np.eye(2)
        self.xEst = np.concatenate([self.xEst, m])
        self.PEst = np.block([[self.PEst, cross.T], [cross, corner]])
