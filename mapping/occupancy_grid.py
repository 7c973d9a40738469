"""Log-odds occupancy grid (binary Bayes filter per cell), with ROS map_server export.

Model
-----
Each cell m holds the log-odds ``l = log(p / (1 − p))`` of being occupied. With the inverse
sensor model ``p(m | z)`` and the prior ``p0`` (``l0 = logit p0``), one scan updates

    l_t = l_{t−1} + logit p(m | z_t) − l0                                   (Thrun et al. 9.2)

with ``p(m | z) = p_hit = 0.7`` for the cell holding a beam end point and ``p_miss = 0.4``
for the cells the beam passes through (the notes' defaults; ``l0 = 0`` for ``p0 = 0.5``).
Per scan a cell is updated at most once: the free cells and the hit cells of all beams are
deduplicated, and a cell that one beam passes and another ends in counts as a hit.
Readings at or beyond ``max_range`` are "no return": they clear the cells up to
``min(range, clear_range)`` but mark no hit. NaN, inf, zero and negative readings are
rejected (and counted by the caller). With ``hit_guard = g > 0`` the cells within ``g`` cells
(Chebyshev) of a hit of the same scan are not cleared either: rays that graze a wall cross
its cells just before their own end points, and between the (sparse, at grazing angles) hits
they would otherwise erase the wall. ``l`` is clamped to ``[l_min, l_max]`` (configurable,
``None`` disables) so a cell can change its mind after the world changes.

Thresholds: ``p < 0.25`` free, ``p > 0.65`` occupied, otherwise unknown. ROS int8 grid:
0 free, 100 occupied, −1 unknown.

Frames and indices
------------------
``log_odds[iy, ix]`` (rows are y). ``origin`` is the world position of the lower-left
corner of cell ``(0, 0)`` (as in a map_server YAML), so the centre of cell ``(ix, iy)`` is
``origin + (i + ½)·resolution``. World → cell is rounding relative to the centre of cell 0,

    i = round((w − origin − ½·res) / res) = ⌊(w − origin) / res⌋,

the half-cell origin shift the notes mention (their formula ``(w − origin) / res`` leaves out
both the rounding and the shift; see research/method/grid_mapping.md). The grid grows in whole blocks of
cells when a scan reaches beyond it, keeping every existing cell at its world position.

Bad input raises ``ValueError`` before anything changes: ranges and angles of different shapes, a
non-finite pose or mount, and a scan whose growth the machine cannot hold (the grown log-odds and the
tracing's int64 scratch beyond the memory available: a 1e5 m reading at 5 cm cells asks for terabytes)
— such a reading is not a measurement; give ``max_range`` or drop it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import NonNegativeInt, PositiveFloat, PositiveInt, model_validator

from slamarena.datasets.geometry import compose, transform_points
from slamarena.params import Field, Params
from slamarena.resources import fits_in_memory, gib

from .raytrace import bresenham

__all__ = [
    "OccupancyGrid",
    "OccupancyGridParams",
    "CellModelParams",
    "logit",
    "probability",
    "load_map_server",
    "ROS_FREE",
    "ROS_OCCUPIED",
    "ROS_UNKNOWN",
]

ROS_FREE, ROS_OCCUPIED, ROS_UNKNOWN = 0, 100, -1
#: map_server trinary PGM pixel values (map_saver): occupied black, free white, unknown grey
PGM_OCCUPIED, PGM_FREE, PGM_UNKNOWN = 0, 254, 205
_GROW_BLOCK = 64


def logit(p):
    p = np.asarray(p, dtype=float)
    return np.log(p / (1.0 - p))


def probability(l):
    """Occupancy probability of log-odds ``l`` (``1 − 1/(1 + e^l)``, overflow-free)."""
    return 0.5 * (1.0 + np.tanh(0.5 * np.asarray(l, dtype=float)))


@dataclass
class ScanCells:
    """The deduplicated cells one scan updates (flat indices into the grid)."""

    free: np.ndarray
    hit: np.ndarray


#: a probability strictly between 0 and 1
OpenProbability = Annotated[float, Field(gt=0.0, lt=1.0)]


class CellModelParams(Params):
    """The cell model of a log-odds grid (inverse sensor model, thresholds, clamp, hit guard): the ``cells`` of
    :class:`OccupancyGridParams` and of the map pyramid's :class:`~slamarena.mapping.map_pyramid.PyramidParams`."""

    p_hit: OpenProbability = Field(0.7, description="p(m | z) of the cell holding a beam end point")
    p_miss: OpenProbability = Field(0.4, description="p(m | z) of the cells a beam passes through")
    p_prior: OpenProbability = Field(0.5, description="prior occupancy p0 of an unobserved cell (l0 = logit p0)")
    free_threshold: OpenProbability = Field(0.25, description="a cell with p below this is free")
    occupied_threshold: OpenProbability = Field(0.65, description="a cell with p above this is occupied")
    clamp: tuple[OpenProbability, OpenProbability] | None = Field(
        (0.12, 0.97), description="probabilities (p_min, p_max) the log-odds are clamped to; None: no clamping"
    )
    hit_guard: NonNegativeInt = Field(
        0, description="cells (Chebyshev) around a hit that the same scan does not clear [cells]; 0: off"
    )

    @model_validator(mode="after")
    def _ordered(self):
        if not self.p_miss < self.p_prior < self.p_hit:
            raise ValueError(f"need p_miss < p_prior < p_hit, got {self.p_miss}, {self.p_prior}, {self.p_hit}")
        if not self.free_threshold < self.occupied_threshold:
            raise ValueError(
                f"need free_threshold < occupied_threshold, got {self.free_threshold}, {self.occupied_threshold}"
            )
        if self.clamp is not None and not self.clamp[0] < self.p_prior < self.clamp[1]:
            raise ValueError(f"clamp (p_min, p_max) must lie around p_prior = {self.p_prior}, got {self.clamp}")
        return self


class OccupancyGridParams(Params):
    """Parameters of :class:`OccupancyGrid`: its lattice and its cell model (``cells``)."""

    resolution: PositiveFloat = Field(0.05, description="cell side [m]")
    width: PositiveInt = Field(200, description="initial number of columns (x) [cells]")
    height: PositiveInt = Field(200, description="initial number of rows (y) [cells]")
    origin: tuple[float, float] | None = Field(
        None, description="world position of the lower-left corner of cell (0, 0) [m]; None: the grid centred on (0, 0)"
    )
    grow: bool = Field(
        True, description="grow in blocks of 64 cells when a scan reaches beyond the grid (else drop those cells)"
    )
    dtype: Literal["float32", "float64"] = Field("float32", description="storage type of the log-odds")
    cells: CellModelParams = Field(CellModelParams(), description="the cell model")


class OccupancyGrid:
    """Log-odds occupancy grid; see the module docstring for the model and conventions (:class:`OccupancyGridParams`)."""

    Params = OccupancyGridParams

    def __init__(self, params: OccupancyGridParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        p = self.params
        c = p.cells
        self.origin = np.array(
            p.origin if p.origin is not None else (-0.5 * p.width * p.resolution, -0.5 * p.height * p.resolution),
            dtype=float,
        )
        self.l_hit, self.l_miss, self.l0 = float(logit(c.p_hit)), float(logit(c.p_miss)), float(logit(c.p_prior))
        self.l_min, self.l_max = (
            (float(logit(c.clamp[0])), float(logit(c.clamp[1]))) if c.clamp is not None else (-np.inf, np.inf)
        )
        self.log_odds = np.full((p.height, p.width), self.l0, dtype=p.dtype)
        self.version = 0
        self.cell_updates = 0

    # ------------------------------------------------------------------ geometry
    @property
    def shape(self) -> tuple[int, int]:
        return self.log_odds.shape

    def world_to_grid(self, xy) -> np.ndarray:
        """Integer cell indices ``(…, 2)`` as ``(ix, iy)``: rounding with the half-cell shift."""
        xy = np.asarray(xy, dtype=float)
        return np.floor((xy - self.origin - 0.5 * self.params.resolution) / self.params.resolution + 0.5).astype(
            np.int64
        )

    def grid_to_world(self, ij) -> np.ndarray:
        """World position ``(…, 2)`` of the centres of cells ``(ix, iy)``."""
        return self.origin + (np.asarray(ij, dtype=float) + 0.5) * self.params.resolution

    def contains(self, ij) -> np.ndarray:
        ij = np.asarray(ij)
        h, w = self.shape
        return (ij[..., 0] >= 0) & (ij[..., 0] < w) & (ij[..., 1] >= 0) & (ij[..., 1] < h)

    def _scratch(self) -> np.ndarray:
        """An int64 array of the grid's size for :meth:`scan_cells` (its contents are never read before written)."""
        size = self.shape[0] * self.shape[1]
        if getattr(self, "_scratch_cells", None) is None or self._scratch_cells.size != size:
            self._scratch_cells = np.empty(size, dtype=np.int64)
        return self._scratch_cells

    def release_scratch(self) -> None:
        """Free the scratch array of :meth:`scan_cells` (8 bytes a cell, twice the grid): for a grid that takes no
        more scans (it is made again if one comes)."""
        self._scratch_cells = None

    def ensure_contains(self, xy_min, xy_max) -> None:
        """Grow (in blocks of cells) so the world box ``[xy_min, xy_max]`` lies inside; ``ValueError`` (nothing
        changed) for a box that is not finite or whose grid would not fit in the memory available."""
        box = np.array([xy_min, xy_max], dtype=float)
        if not np.all(np.isfinite(box)):
            raise ValueError(f"the occupancy grid cannot grow to a non-finite box {box.tolist()}")
        res = self.params.resolution
        h, w = self.shape
        lo = np.floor((box[0] - self.origin) / res)  # in floats: a huge box must not wrap around int64
        hi = np.floor((box[1] - self.origin) / res)
        pad_lo = np.maximum(-lo, 0)
        pad_hi = np.maximum(hi - np.array([w - 1, h - 1]), 0)
        if not (pad_lo.any() or pad_hi.any()):
            return
        pad_lo = -(-pad_lo // _GROW_BLOCK) * _GROW_BLOCK
        pad_hi = -(-pad_hi // _GROW_BLOCK) * _GROW_BLOCK
        with np.errstate(over="ignore"):  # a box of 1e300 m overflows to inf cells: refused below
            cells = (w + pad_lo[0] + pad_hi[0]) * (h + pad_lo[1] + pad_hi[1])
        need = cells * (self.log_odds.itemsize + 8)  # the log-odds and scan_cells' int64 scratch
        fits, free = fits_in_memory(need)
        if not fits:
            raise ValueError(
                f"the occupancy grid would grow to {cells:.3g} cells to hold the box {box.tolist()} [m] at {res} m: "
                f"{gib(need)} with the tracing's scratch, beyond the {gib(free)} of memory available; a reading that "
                "long is not a measurement (give max_range, or drop it); the grid is unchanged"
            )
        pad_lo, pad_hi = pad_lo.astype(np.int64), pad_hi.astype(np.int64)
        self.log_odds = np.pad(self.log_odds, ((pad_lo[1], pad_hi[1]), (pad_lo[0], pad_hi[0])), constant_values=self.l0)
        self.origin = self.origin - pad_lo * self.params.resolution
        self.version += 1

    # ------------------------------------------------------------------ update
    def scan_cells(
        self, ranges, angles, pose, mount=(0.0, 0.0, 0.0), max_range: float = np.inf, clear_range: float | None = None
    ) -> ScanCells:
        """The free and hit cells of one scan (deduplicated; a hit wins over free).

        ``pose`` is the robot pose, ``mount`` the sensor pose in the robot frame. Invalid
        readings (non-finite, ≤ 0) are ignored; readings ``≥ max_range`` clear space up
        to ``min(range, clear_range)`` (``clear_range`` default: ``max_range``) without a hit.
        Grows the grid (if enabled) so every traced cell lies inside; otherwise cells
        outside the grid are dropped. ``ValueError`` (the grid unchanged) for ranges and angles of different
        shapes, a non-finite pose or mount, or a growth beyond the memory available (:meth:`ensure_contains`).
        """
        r = np.asarray(ranges, dtype=float)
        a = np.asarray(angles, dtype=float)
        if r.ndim != 1 or a.shape != r.shape:
            raise ValueError(f"ranges and angles must be 1-D of one length, got shapes {r.shape} and {a.shape}")
        pose, mount = np.asarray(pose, dtype=float), np.asarray(mount, dtype=float)
        if pose.shape != (3,) or mount.shape != (3,) or not (np.all(np.isfinite(pose)) and np.all(np.isfinite(mount))):
            raise ValueError(f"pose and mount must be finite (x, y, θ), got {pose.tolist()} and {mount.tolist()}")
        valid = np.isfinite(r) & (r > 0)
        hit = valid & (r < max_range)
        reach = np.where(hit, r, np.minimum(r, max_range if clear_range is None else clear_range))
        reach = reach[valid]
        hit = hit[valid]
        sensor = compose(pose, mount)
        if reach.size == 0:
            return ScanCells(np.zeros(0, np.int64), np.zeros(0, np.int64))
        ends = transform_points(sensor, np.column_stack([reach * np.cos(a[valid]), reach * np.sin(a[valid])]))
        if self.params.grow:
            self.ensure_contains(np.minimum(ends.min(axis=0), sensor[:2]), np.maximum(ends.max(axis=0), sensor[:2]))
        c0 = self.world_to_grid(sensor[:2])
        c1 = self.world_to_grid(ends)
        x, y, line, step = bresenham(c0[0], c0[1], c1[:, 0], c1[:, 1])
        is_end = step == np.maximum(np.abs(c1[:, 0] - c0[0]), np.abs(c1[:, 1] - c0[1]))[line]
        is_hit = is_end & hit[line]
        inside = self.contains(np.column_stack([x, y]))
        flat = (y * self.shape[1] + x)[inside]
        is_hit = is_hit[inside]
        # one entry per cell without sorting: write every entry's position into a scratch grid and keep the entries
        # that read their own position back (one per cell); then mark the guarded cells (−2) and the hit cells (−1):
        # a hit wins over free, and a guarded cell is not cleared
        scratch = self._scratch()
        position = np.arange(flat.size)
        scratch[flat] = position
        cells = flat[scratch[flat] == position]
        hits = flat[is_hit]
        if self.params.cells.hit_guard and hits.size:
            g = np.arange(-self.params.cells.hit_guard, self.params.cells.hit_guard + 1)
            hx, hy = hits % self.shape[1], hits // self.shape[1]
            gx, gy = (
                v.ravel()
                for v in np.broadcast_arrays(hx[:, None, None] + g[None, None, :], hy[:, None, None] + g[None, :, None])
            )
            near = (gx >= 0) & (gx < self.shape[1]) & (gy >= 0) & (gy < self.shape[0])
            scratch[gy[near] * self.shape[1] + gx[near]] = -2
        scratch[hits] = -1
        mark = scratch[cells]
        hits, free = cells[mark == -1], cells[mark >= 0]
        return ScanCells(free, hits)

    def apply(self, cells: ScanCells) -> int:
        """Apply one scan's update ``l += logit p(m|z) − l0`` with clamping; returns cells updated."""
        flat = self.log_odds.reshape(-1)
        for idx, l_meas in ((cells.free, self.l_miss), (cells.hit, self.l_hit)):
            flat[idx] = np.clip(flat[idx] + (l_meas - self.l0), self.l_min, self.l_max)
        n = int(cells.free.size + cells.hit.size)
        self.cell_updates += n
        self.version += 1
        return n

    def cells_in(self, cells: ScanCells, other: OccupancyGrid) -> ScanCells:
        """``cells`` (flat indices of this grid) as flat indices of ``other``, a grid on the same lattice (same
        resolution, origins a whole number of cells apart): the same world cells, so one scan traced once updates
        several grids. ``other`` grows to hold them (if it grows; else the cells outside it are dropped)."""
        res = self.params.resolution
        offset = (self.origin - other.origin) / res
        if other.params.resolution != res or not np.allclose(offset, np.rint(offset), rtol=0.0, atol=1e-6):
            raise ValueError(
                f"grids not on one lattice: resolutions {res}, {other.params.resolution}, origins {self.origin}, {other.origin}"
            )
        w = self.shape[1]
        both = np.concatenate([cells.free, cells.hit])
        if both.size == 0:
            return ScanCells(cells.free.copy(), cells.hit.copy())
        x, y = both % w, both // w
        if other.params.grow:
            other.ensure_contains(self.grid_to_world([x.min(), y.min()]), self.grid_to_world([x.max(), y.max()]))
        dx, dy = np.rint((self.origin - other.origin) / res).astype(np.int64)
        x, y = x + dx, y + dy
        inside = other.contains(np.column_stack([x, y]))
        flat = y * other.shape[1] + x
        is_free = np.arange(both.size) < cells.free.size
        return ScanCells(flat[inside & is_free], flat[inside & ~is_free])

    def integrate(
        self, ranges, angles, pose, mount=(0.0, 0.0, 0.0), max_range: float = np.inf, clear_range: float | None = None
    ) -> int:
        """Trace and apply one scan (see :meth:`scan_cells`); returns the number of cells updated."""
        return self.apply(self.scan_cells(ranges, angles, pose, mount, max_range, clear_range))

    # ------------------------------------------------------------------ views
    def probability(self) -> np.ndarray:
        return probability(self.log_odds)

    def to_ros(self) -> np.ndarray:
        """int8 grid (rows = y): 0 free (p < free), 100 occupied (p > occupied), −1 unknown."""
        p = self.probability()
        out = np.full(p.shape, ROS_UNKNOWN, dtype=np.int8)
        out[p < self.params.cells.free_threshold] = ROS_FREE
        out[p > self.params.cells.occupied_threshold] = ROS_OCCUPIED
        return out

    def nbytes(self) -> int:
        return int(self.log_odds.nbytes)

    # ------------------------------------------------------------------ export
    def save_png(self, path: str | Path, crop: bool = True) -> Path:
        """Greyscale image of ``1 − p`` (white free, black occupied), north up."""
        import matplotlib.image

        img = (255.0 * (1.0 - self.probability())).astype(np.uint8)
        if crop:
            img = img[self._known_box()]
        path = Path(path)
        matplotlib.image.imsave(path, img[::-1], cmap="gray", vmin=0, vmax=255)
        return path

    def save_map_server(self, stem: str | Path) -> tuple[Path, Path]:
        """Write ``stem.pgm`` (trinary P5) and ``stem.yaml`` in the ROS map_server format.

        Pixels: occupied 0, free 254, unknown 205 (as map_saver writes them). In the YAML,
        ``free_thresh`` is 0.196 and not the grid's 0.25: map_server reads a pixel v as
        ``p = (255 − v) / 255`` and calls it free when ``p < free_thresh``; the unknown grey
        205 gives p = 0.196, which a threshold of 0.25 would turn into free space.
        """
        import yaml

        stem = Path(stem)
        ros = self.to_ros()
        pgm = np.full(ros.shape, PGM_UNKNOWN, dtype=np.uint8)
        pgm[ros == ROS_FREE] = PGM_FREE
        pgm[ros == ROS_OCCUPIED] = PGM_OCCUPIED
        h, w = pgm.shape
        pgm_path = stem.with_suffix(".pgm")
        with open(pgm_path, "wb") as fh:
            fh.write(f"P5\n# slamarena occupancy grid, {self.params.resolution} m/cell\n{w} {h}\n255\n".encode("ascii"))
            fh.write(pgm[::-1].tobytes())
        yaml_path = stem.with_suffix(".yaml")
        meta = {
            "image": pgm_path.name,
            "mode": "trinary",
            "resolution": self.params.resolution,
            "origin": [float(self.origin[0]), float(self.origin[1]), 0.0],
            "negate": 0,
            "occupied_thresh": self.params.cells.occupied_threshold,
            "free_thresh": 0.196,
        }
        yaml_path.write_text(yaml.safe_dump(meta, sort_keys=False))
        return pgm_path, yaml_path

    def _known_box(self) -> tuple[slice, slice]:
        known = np.abs(self.log_odds - self.l0) > 1e-6
        if not known.any():
            return slice(None), slice(None)
        rows = np.flatnonzero(known.any(axis=1))
        cols = np.flatnonzero(known.any(axis=0))
        return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def load_map_server(yaml_path: str | Path) -> tuple[np.ndarray, float, np.ndarray]:
    """Read a map_server YAML + PGM as map_server does: ``(ros int8 grid rows=y, resolution, origin)``."""
    import yaml

    yaml_path = Path(yaml_path)
    meta = yaml.safe_load(yaml_path.read_text())
    data = (yaml_path.parent / meta["image"]).read_bytes()
    tokens, pos = [], 0
    while len(tokens) < 4:
        while data[pos : pos + 1].isspace():
            pos += 1
        if data[pos : pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end : end + 1].isspace():
            end += 1
        tokens.append(data[pos:end])
        pos = end
    magic, w, h, maxval = tokens[0], int(tokens[1]), int(tokens[2]), int(tokens[3])
    if magic != b"P5" or maxval != 255:
        raise ValueError(f"{meta['image']}: expected an 8-bit P5 PGM")
    pixels = np.frombuffer(data[pos + 1 : pos + 1 + w * h], dtype=np.uint8).reshape(h, w)[::-1]
    p = (255.0 - pixels) / 255.0 if not meta.get("negate", 0) else pixels / 255.0
    ros = np.full((h, w), ROS_UNKNOWN, dtype=np.int8)
    ros[p > meta["occupied_thresh"]] = ROS_OCCUPIED
    ros[p < meta["free_thresh"]] = ROS_FREE
    return ros, float(meta["resolution"]), np.asarray(meta["origin"][:2], dtype=float)
