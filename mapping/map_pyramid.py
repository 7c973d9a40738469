"""A multi-resolution stack of occupancy grids, all updated from the same scans (Hector SLAM).

Level k has resolution ``resolution · 2^k``; level 0 is the finest. Each level is an
independent :class:`~slamarena.mapping.occupancy_grid.OccupancyGrid` with the same cell model (origin
shifted by half a cell so that cell centres lie on multiples of the level's resolution), so
the coarse levels are true coarse maps (not blurred copies of the fine one): a scan
matched on level k sees smooth, wide basins, the fine level gives accuracy.
"""
from __future__ import annotations

import numpy as np

from .occupancy_grid import OccupancyGrid

__all__ = ["MapPyramid"]


class MapPyramid:
    def __init__(self, resolution: float = 0.05, levels: int = 3, size: float = 20.0, centre=(0.0, 0.0), **grid_params):
        """``size`` [m]: the initial square around ``centre`` (grids grow as scans reach beyond)."""
        if levels < 1:
            raise ValueError("levels must be ≥ 1")
        self.levels: list[OccupancyGrid] = []
        for k in range(levels):
            res = resolution * 2**k
            n = max(int(np.ceil(size / res)), 1)
            corner = np.round(np.asarray(centre, dtype=float) / res) * res - (n // 2 + 0.5) * res  # half-cell shift: cell centres on multiples of res
            self.levels.append(OccupancyGrid(resolution=res, width=n, height=n, origin=tuple(corner), **grid_params))
        self.version = 0

    @property
    def finest(self) -> OccupancyGrid:
        return self.levels[0]

    def integrate(self, ranges, angles, pose, mount=(0.0, 0.0, 0.0), max_range: float = np.inf, clear_range: float | None = None) -> int:
        """Integrate one scan into every level; returns the cells updated on the finest level."""
        n = [g.integrate(ranges, angles, pose, mount, max_range, clear_range) for g in self.levels]
        self.version += 1
        return n[0]

    def nbytes(self) -> int:
        return sum(g.nbytes() for g in self.levels)
