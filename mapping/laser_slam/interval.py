"""The covariance of a front-end relative pose: the odometry's, accumulated over the interval it spans, fused in
information form with what the scan match at its end constrains (research/method/laser_degeneracy.md, "Covariance").

Odometry noise (:class:`OdometryNoiseParams`, a random walk per distance, as the ``sim:laser`` odometry): an odometry
motion u = (dx, dy, dθ) (3,) between two scans, d = ‖(dx, dy)‖, a = |dθ|, has in its end's frame

    Σ_u = diag(k_t² d, k_s² d, k_r² a + k_rt² d)                                                      (3, 3)

so variances add over consecutive motions whatever the scan rate (a σ proportional to the motion, as the RBPF's
proposal model, would shrink when a stretch is cut into more scans).

Accumulation (:class:`IntervalCovariance`): from the scan of node i − 1 (Q = 0) to scan k, each motion u_k composes
T_k = T_{k−1} u_k; a right perturbation ε of T_{k−1} is Ad_{u_k⁻¹} ε at T_k (GTSAM's Pose2 convention), so

    Q_k = Ad_{u_k⁻¹} Q_{k−1} Ad_{u_k⁻¹}ᵀ + Σ_{u_k}                                                     (3, 3)

in scan k's frame, where GTSAM's BetweenFactorPose2 measures a factor's error. A scan whose odometry says nothing
(none, non-finite) leaves Q undefined until the next node: the relative pose then has the match's covariance only.

Fusion (:func:`fuse`): the scan match at the interval's end constrains the directions its information I (3, 3, the
match's H/σ̂² projected onto the kept directions of a degenerate match, scan frame) covers, the odometry the rest:

    Σ = (Q⁻¹ + I)⁻¹ = Q (I₃ + I Q)⁻¹                                                                  (3, 3)

(the second form needs no inverse of Q, which is singular for an interval without motion). Along a degenerate
direction I has nothing and Σ is the odometry's accumulated variance; where the scan constrains, the scan's.
"""

from __future__ import annotations

import numpy as np
from pydantic import NonNegativeFloat

from slamarena.datasets.geometry import inverse, wrap_angle
from slamarena.params import Field, Params

from .consistency import adjoint

__all__ = ["IntervalCovariance", "OdometryNoiseParams", "fuse"]


class OdometryNoiseParams(Params):
    """The odometry's noise (module docstring): variance per metre along and across the motion and in heading, per
    radian turned in heading. Defaults: the ``sim:laser`` odometry's stated noise (chosen on no staged log)."""

    k_t: NonNegativeFloat = Field(0.02, description="noise along the motion [m/√m]")
    k_s: NonNegativeFloat = Field(0.01, description="noise across the motion [m/√m]")
    k_r: NonNegativeFloat = Field(0.03, description="heading noise per turn [rad/√rad]")
    k_rt: NonNegativeFloat = Field(0.01, description="heading noise per distance [rad/√m]")

    def cov(self, motion: np.ndarray) -> np.ndarray:
        """Σ_u (3, 3) of an odometry motion (dx, dy, dθ) (3,)."""
        d, a = float(np.hypot(motion[0], motion[1])), abs(float(wrap_angle(motion[2])))
        return np.diag([self.k_t**2 * d, self.k_s**2 * d, self.k_r**2 * a + self.k_rt**2 * d])


class IntervalCovariance:
    """Q (3, 3) of the odometry's motion since the last :meth:`reset` (module docstring); None when undefined."""

    def __init__(self, noise: OdometryNoiseParams):
        self.noise = noise
        self.Q: np.ndarray | None = np.zeros((3, 3))

    def step(self, motion: np.ndarray | None) -> None:
        """One scan's odometry motion u (3,) (None: the odometry says nothing, Q becomes undefined)."""
        if motion is None or self.Q is None:
            self.Q = None
            return
        A = adjoint(inverse(motion))
        self.Q = A @ self.Q @ A.T + self.noise.cov(motion)

    def reset(self) -> None:
        """A node: the next interval starts here."""
        self.Q = np.zeros((3, 3))


def fuse(Q: np.ndarray, information: np.ndarray) -> np.ndarray:
    """Σ = (Q⁻¹ + I)⁻¹ = Q (I₃ + I Q)⁻¹ (3, 3), symmetric (module docstring)."""
    S = Q @ np.linalg.inv(np.eye(3) + information @ Q)
    return 0.5 * (S + S.T)
