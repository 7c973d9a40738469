"""Relations files (Kümmerle et al., "On measuring the accuracy of SLAM algorithms", AuRo 2009).

One relation per line, ``t1 t2 x y z roll pitch yaw``: the motion of the robot from the scan with
ipc_timestamp ``t1`` to the scan with ipc_timestamp ``t2``, in the frame of the first scan
(metres, radians). The timestamps refer to the ORIGINAL log stamps (a CARMEN Sequence keeps them in
``meta["scan_ipc_timestamp"]``). Some published files carry a leading tag per line (``FLASER``…):
a first non-numeric token is skipped when every line has one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ._text import bodies_of, fixed, records

__all__ = ["Relations", "read", "write"]


@dataclass(frozen=True)
class Relations:
    """t1, t2 (N,) timestamps; motion (N, 6) ``x y z roll pitch yaw`` of t2 in the frame of t1."""

    t1: np.ndarray
    t2: np.ndarray
    motion: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "t1", np.ascontiguousarray(self.t1, dtype=float))
        object.__setattr__(self, "t2", np.ascontiguousarray(self.t2, dtype=float))
        object.__setattr__(self, "motion", np.ascontiguousarray(self.motion, dtype=float).reshape(-1, 6))
        if not (self.t1.shape == self.t2.shape == self.motion.shape[:1]):
            raise ValueError("Relations: t1, t2 and motion differ in length")

    def __len__(self) -> int:
        return int(self.t1.shape[0])

    @property
    def se2(self) -> np.ndarray:
        """The planar part ``(x, y, yaw)`` (N, 3)."""
        return self.motion[:, [0, 1, 5]]


def read(path: str | Path) -> Relations:
    lines, tag = records(path, "a relation: t1 t2 x y z roll pitch yaw")
    rows = np.flatnonzero(tag != "")
    first_numeric = np.array([_is_number(t) for t in tag[rows]], dtype=bool)
    skip = not first_numeric.any()
    if first_numeric.any() and not first_numeric.all():
        k = int(rows[np.flatnonzero(~first_numeric)[0]])
        raise DataFormatError(lines.path, k + 1, "a relation: t1 t2 x y z roll pitch yaw", lines[k][:80])
    v = fixed(
        lines.path, bodies_of(lines, rows, 1 if skip else 0), rows + 1, 8, "a relation (t1 t2 x y z roll pitch yaw)"
    )
    return Relations(t1=v[:, 0], t2=v[:, 1], motion=v[:, 2:8])


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def write(path: str | Path, relations: Relations) -> None:
    """Write ``t1 t2 x y z roll pitch yaw`` lines (17 significant digits: round trip exact)."""
    table = np.column_stack([relations.t1, relations.t2, relations.motion])
    np.savetxt(path, table, fmt="%.17g")
