"""The odometry attached to laser scans, read as readings that may repeat.

Some logs repeat an odometry reading while the robot moves and then jump (mit-csail's FLASER odometry
freezes for four scans at scans 321–325, 798–802 and 1580–1584). A scan's odometry pose ``o_k`` is a
**fresh reading** when it is finite and differs from the last fresh reading; a repeated (or non-finite)
reading is no new reading. A mapper moves a pose by the odometry only at fresh readings, and then by the
increment from the last fresh reading, ``⊖o_f ⊕ o_k``, applied to its pose at that reading (not to its
latest pose, which it may have corrected in between): the motion of the frozen stretch is applied once.

The noise of an odometry motion (:class:`MotionNoiseParams`): Σ_u (3, 3), the RBPF's motion model and the front
end's odometry prior.
"""

from __future__ import annotations

import numpy as np
from pydantic import NonNegativeFloat, PositiveFloat

from slamarena.datasets.geometry import wrap_angle
from slamarena.params import Field, Params

__all__ = ["MotionNoiseParams", "fresh_readings"]


def fresh_readings(odometry: np.ndarray) -> np.ndarray:
    """(K,) bool: whether scan k's odometry pose (K, 3) is a fresh reading (module docstring)."""
    odometry = np.asarray(odometry, dtype=float).reshape(-1, 3)
    fresh = np.zeros(len(odometry), bool)
    last = None
    for k, o in enumerate(odometry):
        if np.all(np.isfinite(o)) and (last is None or np.any(o != last)):
            fresh[k] = True
            last = o
    return fresh


class MotionNoiseParams(Params):
    """The odometry motion model's noise: Σ_u = diag(σ_t², σ_t², σ_r²) with
    ``σ_t = sigma_t_min + sigma_t_per_m·d + sigma_t_per_rad·|Δθ|`` and
    ``σ_r = sigma_r_min + sigma_r_per_rad·|Δθ| + sigma_r_per_m·d`` for an odometry motion of d metres and
    Δθ radians (isotropic in translation, hence the same in every frame)."""

    sigma_t_min: PositiveFloat = Field(0.1, description="σ_t of the motion model at rest [m]")
    sigma_t_per_m: NonNegativeFloat = Field(0.1, description="σ_t per metre travelled [m/m]")
    sigma_t_per_rad: NonNegativeFloat = Field(0.05, description="σ_t per radian turned [m/rad]")
    sigma_r_min: PositiveFloat = Field(0.1, description="σ_r of the motion model at rest [rad]")
    sigma_r_per_rad: NonNegativeFloat = Field(0.1, description="σ_r per radian turned [rad/rad]")
    sigma_r_per_m: NonNegativeFloat = Field(0.05, description="σ_r per metre travelled [rad/m]")

    def cov(self, motion: np.ndarray) -> np.ndarray:
        """Σ_u (3, 3) of an odometry motion ``(dx, dy, dθ)``."""
        d, a = float(np.hypot(motion[0], motion[1])), abs(float(wrap_angle(motion[2])))
        st = self.sigma_t_min + self.sigma_t_per_m * d + self.sigma_t_per_rad * a
        sr = self.sigma_r_min + self.sigma_r_per_rad * a + self.sigma_r_per_m * d
        return np.diag([st**2, st**2, sr**2])
