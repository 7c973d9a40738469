"""Copy-on-write tiled log-odds grids: one grid per particle, tiles shared between particles.

Storage
-------
One level of the map of P particles is a **tile pool** ``pool[c, v, u]`` (C tiles of T × T float32
log-odds, T = ``tile``), a **reference count** ``refs[c]`` and a **tile table per particle**
``table[p, ty, tx]`` (int32; −1: the tile was never written, every cell holds the prior ``l0``).
Cell ``(ix, iy)`` of particle p (the conventions of :mod:`slamarena.mapping.occupancy_grid`: ``origin`` the
lower-left corner of cell (0, 0), ``i = ⌊(w − origin)/res⌋``) lives in tile ``table[p, iy // T, ix // T]`` at
``(iy mod T, ix mod T)``. Cells outside the table hold ``l0`` as well: the map is the prior everywhere it
was not observed.

Invariant: ``refs[c]`` is the number of table entries (over all particles) that name tile c; tiles with
``refs = 0`` are on the free list. Hence

* **resampling** copies tables only: ``table ← table[a]`` for the ancestor indices ``a`` (P,), and the counts
  are recounted (``refs = bincount(table)``); tiles nobody names any more return to the free list;
* **a write** by particle p into tile c with ``refs[c] > 1`` first copies c into a free tile c′,
  ``refs[c] −= 1``, ``table[p, ty, tx] = c′`` (copy on write); a write into a never-written tile
  allocates one filled with ``l0``. A write therefore never changes another particle's cells.

Update
------
Each particle integrates a scan from its own sensor pose with the model of
:class:`~slamarena.mapping.occupancy_grid.OccupancyGrid` (same ray tracing, the closed-form integer
Bresenham of :mod:`slamarena.mapping.raytrace`; each cell updated at most once per scan, a hit wins over a
pass, ``hit_guard``, clamping, float32 arithmetic), so one particle's cells equal those of an
``OccupancyGrid`` that integrated the same scans (tested cell for cell). One numba kernel handles all
particles of a level: per particle it traces the rays into an update list (deduplicated with a stamp per
cell), counts the tiles it must allocate or copy, and either applies the whole update or — when the pool
has too few free tiles — stops before writing anything, so that the caller grows the pool and resumes
with that particle.

Memory: ``memory()`` reports the bytes in use (tiles referenced + tables), that divided by P, and what P
unshared grids of the same tiles would take.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..map_pyramid import PyramidParams
from ..occupancy_grid import CellModelParams, OccupancyGrid, logit

__all__ = ["TiledGrid", "TiledPyramid"]


@njit(cache=True)
def _cell(w, origin, res):
    # OccupancyGrid.world_to_grid, literally (the same floating-point expression)
    return int(np.floor((w - origin - 0.5 * res) / res + 0.5))


@njit(cache=True)
def _integrate(
    pool,
    refs,
    free,
    n_free,
    table,
    mark,
    tile_mark,
    stamp,
    T,
    ox,
    oy,
    res,
    sensors,
    reach,
    angles,
    hit,
    guard,
    which,
    start,
    l0,
    d_miss,
    d_hit,
    l_min,
    l_max,
):
    """Integrate one scan into the grids of particles ``which[start:]``; returns the index into ``which``
    where it stopped for want of free tiles (``len(which)`` when done) and the tiles that particle needs.

    ``sensors`` (P, 3) sensor poses; ``reach``, ``angles``, ``hit`` (n,) the beams (``hit``: the end cell is
    a hit, else the ray only clears); ``mark`` (H, W) and ``tile_mark`` (TY, TX) scratch stamps; ``stamp``
    (1,) the last stamp used; ``n_free`` (1,) the free-list length.
    """
    H = mark.shape[0]
    W = mark.shape[1]
    n = reach.shape[0]
    ex = np.empty(n, np.int64)
    ey = np.empty(n, np.int64)
    for w in range(start, which.shape[0]):
        p = which[w]
        stamp[0] += 1
        s = stamp[0]
        protect = 3 * s
        cleared = 3 * s + 1
        applied = 3 * s + 2
        sx, sy, sth = sensors[p, 0], sensors[p, 1], sensors[p, 2]
        c, si = np.cos(sth), np.sin(sth)
        x0 = _cell(sx, ox, res)
        y0 = _cell(sy, oy, res)
        total = 0
        for b in range(n):
            lx = reach[b] * np.cos(angles[b])
            ly = reach[b] * np.sin(angles[b])
            ex[b] = _cell(sx + c * lx - si * ly, ox, res)
            ey[b] = _cell(sy + si * lx + c * ly, oy, res)
            total += max(abs(ex[b] - x0), abs(ey[b] - y0)) + 1
        # hits and the cells the hit guard keeps from being cleared
        for b in range(n):
            if hit[b]:
                for gy in range(-guard, guard + 1):
                    for gx in range(-guard, guard + 1):
                        qx = ex[b] + gx
                        qy = ey[b] + gy
                        if 0 <= qx < W and 0 <= qy < H:
                            mark[qy, qx] = protect
        cells = np.empty(total, np.int64)
        delta = np.empty(total, np.float32)
        m = 0
        for b in range(n):
            dx = ex[b] - x0
            dy = ey[b] - y0
            ax = abs(dx)
            ay = abs(dy)
            D = max(ax, ay)
            mn = min(ax, ay)
            sgx = 1 if dx > 0 else (-1 if dx < 0 else 0)
            sgy = 1 if dy > 0 else (-1 if dy < 0 else 0)
            last = D - 1 if hit[b] else D
            for i in range(last + 1):
                minor = (2 * i * mn + D - 1) // max(2 * D, 1)
                if ax >= ay:
                    qx = x0 + sgx * i
                    qy = y0 + sgy * minor
                else:
                    qx = x0 + sgx * minor
                    qy = y0 + sgy * i
                if qx < 0 or qy < 0 or qx >= W or qy >= H:
                    continue
                v = mark[qy, qx]
                if v == protect or v == cleared:
                    continue
                mark[qy, qx] = cleared
                cells[m] = qy * W + qx
                delta[m] = d_miss
                m += 1
        for b in range(n):
            if hit[b]:
                qx = ex[b]
                qy = ey[b]
                if qx < 0 or qy < 0 or qx >= W or qy >= H or mark[qy, qx] == applied:
                    continue
                mark[qy, qx] = applied
                cells[m] = qy * W + qx
                delta[m] = d_hit
                m += 1
        # tiles to allocate or copy
        need = 0
        for j in range(m):
            ty = (cells[j] // W) // T
            tx = (cells[j] % W) // T
            if tile_mark[ty, tx] != s:
                tile_mark[ty, tx] = s
                t = table[p, ty, tx]
                if t < 0 or refs[t] > 1:
                    need += 1
        if need > n_free[0]:
            return w, need
        for j in range(m):
            qy = cells[j] // W
            qx = cells[j] % W
            ty = qy // T
            tx = qx // T
            t = table[p, ty, tx]
            if t < 0 or refs[t] > 1:
                n_free[0] -= 1
                t2 = free[n_free[0]]
                if t < 0:
                    pool[t2] = l0
                    refs[t2] = 1
                else:
                    pool[t2] = pool[t]
                    refs[t] -= 1
                    refs[t2] = 1
                table[p, ty, tx] = t2
                t = t2
            v = pool[t, qy - ty * T, qx - tx * T] + delta[j]
            pool[t, qy - ty * T, qx - tx * T] = min(max(v, l_min), l_max)
    return which.shape[0], 0


class TiledGrid:
    """One level of the maps of ``particles`` particles in copy-on-write tiles (module docstring).

    ``cell_model``: a :class:`~slamarena.mapping.occupancy_grid.CellModelParams` (or its fields); ``resolution`` [m];
    ``tile`` cells per tile side; the table initially covers ``size`` [m] around ``centre`` with cell centres on
    multiples of the resolution (as :class:`~slamarena.mapping.map_pyramid.MapPyramid`) and grows in whole tiles.
    """

    def __init__(
        self, particles: int, cell_model, resolution: float, tile: int = 64, size: float = 20.0, centre=(0.0, 0.0)
    ):
        self.model = CellModelParams.of(cell_model)
        m = self.model
        self.resolution = float(resolution)
        self.tile = int(tile)
        self.shift = self.tile.bit_length() - 1
        if self.tile != 1 << self.shift:
            raise ValueError(f"tile must be a power of two, got {tile}")
        self.l0 = float(logit(m.p_prior))
        # the arithmetic of OccupancyGrid.apply: float32 cells, float32 increments and bounds
        self.d_miss = np.float32(float(logit(m.p_miss)) - self.l0)
        self.d_hit = np.float32(float(logit(m.p_hit)) - self.l0)
        lo, hi = (float(logit(m.clamp[0])), float(logit(m.clamp[1]))) if m.clamp is not None else (-np.inf, np.inf)
        self.l_min, self.l_max = np.float32(lo), np.float32(hi)
        n = max(int(np.ceil(size / (self.resolution * self.tile))), 1)
        self.origin = (
            np.round(np.asarray(centre, float) / self.resolution) - (n * self.tile) // 2 - 0.5
        ) * self.resolution
        self.table = np.full((particles, n, n), -1, np.int32)
        self.pool = np.empty((0, self.tile, self.tile), np.float32)
        self.refs = np.zeros(0, np.int32)
        self.free = np.zeros(0, np.int32)
        self.n_free = np.zeros(1, np.int64)
        self.stamp = np.zeros(1, np.int64)
        self._scratch()

    # ------------------------------------------------------------------ geometry
    @property
    def particles(self) -> int:
        return self.table.shape[0]

    @property
    def shape(self) -> tuple[int, int]:
        """Cells (rows = y, columns = x) the tables cover."""
        return self.table.shape[1] * self.tile, self.table.shape[2] * self.tile

    def world_to_grid(self, xy) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        return np.floor((xy - self.origin - 0.5 * self.resolution) / self.resolution + 0.5).astype(np.int64)

    def _scratch(self):
        self.mark = np.zeros(self.shape, np.int64)
        self.tile_mark = np.zeros(self.table.shape[1:], np.int64)

    def ensure_contains(self, xy_min, xy_max) -> None:
        """Grow the tables (whole tiles, every cell keeps its world position) to cover the box."""
        lo, hi = self.world_to_grid(xy_min), self.world_to_grid(xy_max)
        h, w = self.shape
        pad_lo = -(-np.maximum(-lo, 0) // self.tile)
        pad_hi = -(-np.maximum(hi - np.array([w - 1, h - 1]), 0) // self.tile)
        if not (pad_lo.any() or pad_hi.any()):
            return
        self.table = np.pad(self.table, ((0, 0), (pad_lo[1], pad_hi[1]), (pad_lo[0], pad_hi[0])), constant_values=-1)
        self.origin = self.origin - pad_lo * self.tile * self.resolution
        self._scratch()

    # ------------------------------------------------------------------ tiles
    def _grow_pool(self, need: int) -> None:
        old = self.pool.shape[0]
        new = max(old + need, 2 * old, 16)
        pool = np.empty((new, self.tile, self.tile), np.float32)
        pool[:old] = self.pool
        self.pool = pool
        self.refs = np.concatenate([self.refs, np.zeros(new - old, np.int32)])
        fresh = np.arange(new - 1, old - 1, -1, dtype=np.int32)  # popped from the end: lowest first
        self.free = np.concatenate([fresh, self.free[: self.n_free[0]]])
        self.n_free[0] = self.free.size

    def resample(self, ancestors) -> None:
        """Particle i takes the map of particle ``ancestors[i]`` (tables copied, tiles shared)."""
        self.table = np.ascontiguousarray(self.table[np.asarray(ancestors, dtype=np.int64)])
        used = self.table[self.table >= 0]
        self.refs = np.bincount(used, minlength=self.pool.shape[0]).astype(np.int32)
        self.free = np.flatnonzero(self.refs == 0)[::-1].astype(np.int32)
        self.n_free[0] = self.free.size

    def integrate(self, sensors, reach, angles, hit, which=None, guard: int | None = None) -> None:
        """Integrate one scan into the maps of particles ``which`` (default all) from their sensor poses.

        ``sensors`` (P, 3) world sensor poses (robot pose ⊕ mount) of all particles; ``reach`` (n,) how far
        each beam traces [m], ``angles`` (n,) its angle in the sensor frame, ``hit`` (n,) whether it ends in a
        hit (else it only clears). Grows the tables to hold every traced cell."""
        sensors = np.ascontiguousarray(sensors, dtype=np.float64).reshape(-1, 3)
        which = (
            np.arange(self.particles, dtype=np.int64)
            if which is None
            else np.asarray(which, dtype=np.int64).reshape(-1)
        )
        reach = np.ascontiguousarray(reach, dtype=np.float64)
        angles = np.ascontiguousarray(angles, dtype=np.float64)
        hit = np.ascontiguousarray(hit, dtype=np.bool_)
        if reach.size == 0 or which.size == 0:
            return
        s = sensors[which]
        c, si = np.cos(s[:, 2:3]), np.sin(s[:, 2:3])
        lx, ly = reach * np.cos(angles), reach * np.sin(angles)
        ex, ey = s[:, :1] + c * lx - si * ly, s[:, 1:2] + si * lx + c * ly
        margin = (self.model.hit_guard + 1) * self.resolution
        self.ensure_contains(
            np.array([min(ex.min(), s[:, 0].min()), min(ey.min(), s[:, 1].min())]) - margin,
            np.array([max(ex.max(), s[:, 0].max()), max(ey.max(), s[:, 1].max())]) + margin,
        )
        start = 0
        while start < which.size:
            start, need = _integrate(
                self.pool,
                self.refs,
                self.free,
                self.n_free,
                self.table,
                self.mark,
                self.tile_mark,
                self.stamp,
                self.tile,
                self.origin[0],
                self.origin[1],
                self.resolution,
                sensors,
                reach,
                angles,
                hit,
                self.model.hit_guard if guard is None else guard,
                which,
                start,
                np.float32(self.l0),
                self.d_miss,
                self.d_hit,
                self.l_min,
                self.l_max,
            )
            if start < which.size:
                self._grow_pool(need)

    # ------------------------------------------------------------------ views
    def dense(self, particle: int) -> OccupancyGrid:
        """Particle ``particle``'s map as an :class:`OccupancyGrid` (a copy; same lattice and cell model)."""
        h, w = self.shape
        grid = OccupancyGrid(
            cells=self.model,
            resolution=self.resolution,
            width=w,
            height=h,
            origin=tuple(self.origin),
            grow=False,
        )
        T = self.tile
        tiles = self.table[particle]
        L = grid.log_odds.reshape(tiles.shape[0], T, tiles.shape[1], T)
        ty, tx = np.nonzero(tiles >= 0)
        L[ty, :, tx, :] = self.pool[tiles[ty, tx]]
        return grid

    def memory(self) -> dict:
        """Bytes: ``used`` (referenced tiles + tables), ``per_particle`` (used / P), ``unshared`` (what P
        private copies of every particle's tiles would take, tables included), ``pool`` (allocated tiles)."""
        tile_bytes = self.tile * self.tile * 4
        referenced = int(np.count_nonzero(self.refs))
        used = referenced * tile_bytes + self.table.nbytes
        unshared = int(np.count_nonzero(self.table >= 0)) * tile_bytes + self.table.nbytes
        return {
            "used": used,
            "per_particle": used / self.particles,
            "unshared": unshared,
            "pool": int(self.pool.nbytes),
        }


class TiledPyramid:
    """The levels ``k = 0 … levels − 1`` (resolution ``resolution · 2^k``, cell model ``cells`` of ``pyramid``, a
    :class:`~slamarena.mapping.map_pyramid.PyramidParams`) of every particle's map, each a :class:`TiledGrid`
    updated from the same scans (as :class:`~slamarena.mapping.map_pyramid.MapPyramid`)."""

    def __init__(self, particles: int, pyramid: PyramidParams, tile: int = 64, size: float = 20.0, centre=(0.0, 0.0)):
        self.levels = [
            TiledGrid(particles, pyramid.cells, pyramid.resolution * 2**k, tile, size, centre)
            for k in range(pyramid.levels)
        ]

    @property
    def finest(self) -> TiledGrid:
        return self.levels[0]

    def integrate(self, sensors, reach, angles, hit, which=None) -> None:
        for grid in self.levels:
            grid.integrate(sensors, reach, angles, hit, which)

    def resample(self, ancestors) -> None:
        for grid in self.levels:
            grid.resample(ancestors)

    def memory(self) -> dict:
        """:meth:`TiledGrid.memory` summed over the levels."""
        out = [grid.memory() for grid in self.levels]
        return {key: sum(m[key] for m in out) for key in out[0]}
