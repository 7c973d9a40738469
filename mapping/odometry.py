"""The odometry attached to laser scans, read as readings that may repeat.

Some logs repeat an odometry reading while the robot moves and then jump (mit-csail's FLASER odometry
freezes for four scans at scans 321–325, 798–802 and 1580–1584). A scan's odometry pose ``o_k`` is a
**fresh reading** when it is finite and differs from the last fresh reading; a repeated (or non-finite)
reading is no new reading. A mapper moves a pose by the odometry only at fresh readings, and then by the
increment from the last fresh reading, ``⊖o_f ⊕ o_k``, applied to its pose at that reading (not to its
latest pose, which it may have corrected in between): the motion of the frozen stretch is applied once.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fresh_readings"]


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
