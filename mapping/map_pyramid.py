"""A multi-resolution stack of occupancy grids, all updated from the same scans (Hector SLAM).

Level k has resolution ``resolution · 2^k``; level 0 is the finest. Each level is an
independent :class:`~slamarena.mapping.occupancy_grid.OccupancyGrid` with the same cell model (origin
shifted by half a cell so that cell centres lie on multiples of the level's resolution), so
the coarse levels are true coarse maps (not blurred copies of the fine one): a scan
matched on level k sees smooth, wide basins, the fine level gives accuracy.
"""

from __future__ import annotations

import zlib

import numpy as np
from pydantic import PositiveFloat, PositiveInt

from slamarena.params import Field, Params

from .occupancy_grid import CellModelParams, OccupancyGrid

__all__ = ["MapPyramid", "MapPyramidParams", "PackedPyramid", "PyramidParams", "initial_side"]


def initial_side(reach: float) -> float:
    """Side [m] of the initial square of a mapping method's maps: twice the reach of the scans that build them
    (the laser's range, or how far a no-return clears, whichever is shorter), at most 100 m (the grids grow as
    scans reach beyond)."""
    return 2.0 * min(reach, 50.0)


class PyramidParams(Params):
    """The levels and the cell model of a map pyramid (the ``pyramid`` of the mapping methods' parameters; the
    extent comes from the data)."""

    resolution: PositiveFloat = Field(
        0.05, description="cell side of the finest level, level 0 [m]; level k has resolution · 2^k"
    )
    levels: PositiveInt = Field(3, description="number of levels")
    cells: CellModelParams = Field(CellModelParams(), description="the cell model of every level")


class MapPyramidParams(PyramidParams):
    """Parameters of :class:`MapPyramid`: :class:`PyramidParams` and the initial extent."""

    size: PositiveFloat = Field(
        20.0, description="side of the initial square every level covers [m] (grids grow as scans reach beyond)"
    )
    centre: tuple[float, float] = Field((0.0, 0.0), description="centre of the initial square [m]")


class MapPyramid:
    """Occupancy grids at resolutions ``resolution · 2^k`` with one cell model (:class:`MapPyramidParams`)."""

    Params = MapPyramidParams

    def __init__(self, params: MapPyramidParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        p = self.params
        self.levels: list[OccupancyGrid] = []
        for k in range(p.levels):
            res = p.resolution * 2**k
            n = max(int(np.ceil(p.size / res)), 1)
            corner = (
                np.round(np.asarray(p.centre) / res) * res - (n // 2 + 0.5) * res
            )  # half-cell shift: cell centres on multiples of res
            self.levels.append(OccupancyGrid(cells=p.cells, resolution=res, width=n, height=n, origin=tuple(corner)))
        self.version = 0

    @classmethod
    def around(cls, pyramid: PyramidParams, centre, reach: float) -> MapPyramid:
        """The maps a mapping method starts with: ``pyramid``'s levels and cell model over the square of side
        :func:`initial_side` (``reach``) centred on ``centre`` (x, y) [m]."""
        return cls(**dict(pyramid), size=initial_side(reach), centre=(float(centre[0]), float(centre[1])))

    @property
    def finest(self) -> OccupancyGrid:
        return self.levels[0]

    def integrate(
        self,
        ranges,
        angles,
        pose,
        mount=(0.0, 0.0, 0.0),
        max_range: float = np.inf,
        clear_range: float | None = None,
        also: tuple[MapPyramid, ...] | list[MapPyramid] = (),
    ) -> int:
        """Integrate one scan into every level; returns the cells updated on the finest level.

        ``also``: other pyramids with the same levels (every pyramid's level k lies on the lattice of cell centres
        at multiples of its resolution) that take the same scan: it is traced once per level and the cells moved
        (:meth:`OccupancyGrid.cells_in`) — the same update as integrating into each, for a third of the tracing
        when a scan goes into three pyramids (laser graph SLAM's tracking map and two submaps)."""
        n = []
        for k, grid in enumerate(self.levels):
            cells = grid.scan_cells(ranges, angles, pose, mount, max_range, clear_range)
            n.append(grid.apply(cells))
            for other in also:
                other.levels[k].apply(grid.cells_in(cells, other.levels[k]))
        for pyramid in (self, *also):
            pyramid.version += 1
        return n[0]

    def nbytes(self) -> int:
        return sum(g.nbytes() for g in self.levels)


class PackedPyramid:
    """A pyramid no scan will change again, stored by its observed tiles: per level the grid's shape, origin and
    counters, the indices of the ``tile`` × ``tile`` blocks of cells holding a log-odds other than the prior ``l0``,
    and those blocks (n, tile, tile), compressed (zlib, lossless); every other cell is ``l0``. :meth:`unpack` rebuilds
    the pyramid exactly.

    Laser graph SLAM keeps every finished submap for the loop search; a submap's grids cover every beam of its scans
    (up to the laser's 80 m), and ~15 % of their cells are observed (FR-Clinic), so most of a dense submap is ``l0``;
    the observed tiles still hold ``l0`` between the rays, and the log-odds take few distinct values (sums of
    ``l_hit`` and ``l_miss``, clamped), which compress well.
    """

    def __init__(self, maps: MapPyramid, tile: int = 16):
        self.params = maps.params
        self.version = maps.version
        self.tile = tile
        self._levels = [self._pack(g) for g in maps.levels]

    def _pack(self, grid: OccupancyGrid) -> dict:
        T, (H, W) = self.tile, grid.shape
        ny, nx = -(-H // T), -(-W // T)
        padded = np.full((ny * T, nx * T), grid.l0, dtype=grid.log_odds.dtype)
        padded[:H, :W] = grid.log_odds
        blocks = padded.reshape(ny, T, nx, T).swapaxes(1, 2)  # (ny, nx, T, T), a view
        observed = (blocks != grid.l0).any(axis=(2, 3))
        return {
            "params": grid.params,
            "shape": (H, W),
            "origin": grid.origin.copy(),
            "version": grid.version,
            "cell_updates": grid.cell_updates,
            "index": np.flatnonzero(observed).astype(np.int32),
            "dtype": grid.log_odds.dtype,
            "blocks": zlib.compress(np.ascontiguousarray(blocks[observed]).tobytes(), 1),
        }

    def unpack(self) -> MapPyramid:
        """The pyramid as it was packed (dense grids, no tracing scratch)."""
        out = MapPyramid.__new__(MapPyramid)
        out.params, out.version, out.levels = self.params, self.version, []
        T = self.tile
        for level in self._levels:
            (H, W), p = level["shape"], level["params"]
            grid = OccupancyGrid(p, width=-(-W // T) * T, height=-(-H // T) * T, origin=tuple(level["origin"]))
            ny, nx = grid.shape[0] // T, grid.shape[1] // T
            iy, ix = np.divmod(level["index"], nx)
            blocks = np.frombuffer(zlib.decompress(level["blocks"]), dtype=level["dtype"]).reshape(-1, T, T)
            grid.log_odds.reshape(ny, T, nx, T).swapaxes(1, 2)[iy, ix] = blocks
            grid.log_odds = np.ascontiguousarray(grid.log_odds[:H, :W])
            grid.origin = level["origin"].copy()
            grid.version, grid.cell_updates = level["version"], level["cell_updates"]
            out.levels.append(grid)
        return out

    def nbytes(self) -> int:
        return sum(len(level["blocks"]) + level["index"].nbytes for level in self._levels)
