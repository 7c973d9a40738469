"""``sim:laser`` — a polygon world with ray-cast 2D laser scans and noisy wheel odometry.

World
-----
A world (:data:`WORLDS`) is a set of wall polylines — line segments of zero thickness, metres —
and a closed **route**, a polygon of waypoints the robot follows with its corners rounded
by circular fillets of radius ``corner_radius``. ``"loop"``: a 4 m wide corridor around a
central block (24 m × 16 m outside) with alcoves and pillars, so that corridors are not
featureless. ``"long_loop"``: the same kind at 56 m × 36 m outside (:func:`corridor_loop`: the
outer walls the rectangle [0, 56] × [0, 36], a 48 m × 28 m block [4, 52] × [4, 32], the route the
corridor's centre line, 165 m a lap, from (28, 2) heading +x; an alcove, pillar or block recess
every 8 m on average), a loop long enough that scan matching drifts by metres before it closes
(research/notebook/2026-11-23-rbpf-loop-rounds-1-3.md "A loop with something to close"). ``"rooms"``: an office floor
(32 m × 22 m) — a ring corridor around a central block, with ten rooms off the corridor behind
1 m doors and some furniture in the rooms. ``"corridor"``: the rectangle [0, 80] × [0, 12] around a 72 m × 4 m
block [4, 76] × [4, 8], two plain 4 m corridors joined at their ends, the route their centre lines (168 m a lap, from
(40, 2) heading +x); with the default 12 m range a scan between x ≈ 16 and 64 m sees two parallel walls and nothing
else, so motion along the corridor is observable from the odometry only (the degeneracy test of
research/method/laser_degeneracy.md). ``"aliased_rooms"``: perceptual aliasing — the long_loop's corridor ring
with a row of identical 4 m rooms behind its outer wall (:func:`room_corridor`), so a place looks like the places
4 m along; ``"distinct_rooms"``: the same walls with every room's door and cabinet shifted differently (the same drive
without aliasing).
:func:`segments` gives a world's walls as ``(S, 4)`` rows ``(x0, y0, x1, y1)``;
:func:`true_occupancy` rasterises them for map IoU.

Motion and odometry
-------------------
The true controls drive the route at ``speed`` (each straight stretched to a whole number of
odometry periods ``dt = 1/odom_rate``; each fillet a whole number of periods at
``ω = α/(n dt)``, ``v = |ω| r``), so the true path, integrated with the exact arc model
(``slamarena.datasets.kinematics``, model ``"arc"``), closes every lap. Ground truth: the true pose at every odometry
stamp ``t_k = t0 + k dt``, ``k = 0 … K`` (``t0`` included).

Wheel odometry: ``Increments`` row k (stamp ``t_{k+1}``) is the body-frame motion from ``t_k``
to ``t_{k+1}``, ``δ̃_k = δ_k + ε_k``, ``ε_k ~ N(0, C_k)`` with a variance that grows with the
motion (so the drift per metre does not depend on the odometry rate)::

    C_k = diag(k_t² |Δs|, k_s² |Δs|, k_r² |Δθ| + k_rt² |Δs|) + 1e-12 I

``Δs`` the true arc length, ``Δθ`` the true turn; ``k_t`` [m/√m] along, ``k_s`` [m/√m] across,
``k_r`` [rad/√rad], ``k_rt`` [rad/√m]. ``Increments.cov`` holds every ``C_k`` (the stated noise).

Scans
-----
Scans at ``scan_rate`` (a divisor of ``odom_rate``), at odometry stamps ``t0 + j/scan_rate``,
``t0`` included. Beam ``b`` of a scan leaves the sensor pose ``x ⊕ mount`` (``x`` the true
pose, ``mount`` the sensor pose in the robot frame) at angle ``angles[b]`` (``fov`` wide,
centred ahead; end points included unless ``fov = 2π``). The reading is the distance to the
nearest wall or pole, ray-cast over all beams × all segments and circles (numpy), plus ``N(0, sigma_range²)``;
a beam that hits nothing within ``max_range`` — or whose noisy reading reaches it, or that
drops out (probability ``dropout``) — reads exactly ``max_range`` ("no return",
``Scans.max_range``). ``Scans.pose`` is the odometry pose (the noisy increments accumulated
from the true start pose) at each scan: what a log attaches to its scans.

Poles
-----
A world may hold **poles**: circles ``(x, y, radius)``, some of them retro-reflective (a beacon). ``"poles"`` (
:func:`pole_field`): an open field 60 m × 40 m inside four walls, 36 tree-like poles of radius 0.05–0.30 m and 8
reflective beacons of radius 0.05 m at fixed positions (a seeded draw at import, at least 3 m apart and at least
2.5 m from the route), the route a rounded rectangle 8 m inside the walls. A world with poles gives each scan
**intensities**: 1 where the beam's return is from a reflective pole, 0 elsewhere (``Scans.intensities``; no return:
0), and its poles as the ground-truth map (``Sequence.landmarks``, ids 0 … in the order of ``World.poles``;
``meta["pole_radius"]``, ``meta["pole_reflective"]``). A ray ``o + t d`` (``|d| = 1``) meets the circle of centre c and
radius ρ at ``t = d·w − √((d·w)² − |w|² + ρ²)``, ``w = c − o`` (:func:`raycast_poles`; a sensor inside a pole sees
nothing of it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import ConfigDict, model_validator

from slamarena.params import Field, Params, with_params
from slamarena.resources import require_memory

from .. import kinematics
from ..geometry import accumulate, compose, wrap_angle
from ..sequence import Increments, LandmarkMap, Noise, Scans, Sequence, Trajectory

__all__ = [
    "World",
    "WORLDS",
    "LaserWorldParams",
    "corridor_loop",
    "pole_field",
    "raycast_poles",
    "room_corridor",
    "segments",
    "raycast",
    "true_occupancy",
    "route_controls",
    "simulate",
]

#: sensor poses × beams × segments evaluated at once by :func:`raycast`
_BLOCK_ELEMENTS = 1_000_000


@dataclass(frozen=True)
class World:
    """Walls (polylines of (x, y) vertices) and the closed route the robot drives."""

    name: str
    walls: tuple
    route: tuple
    corner_radius: float
    description: str
    #: (x, y, radius, reflective) per pole [m, m, m, bool]
    poles: tuple = ()


def _box(x0, y0, x1, y1):
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0))


def _wall_with_doors(fixed: float, lo: float, hi: float, doors, horizontal: bool):
    """A straight wall from ``lo`` to ``hi`` at ``fixed`` with gaps ``[(a, b), …]``; returns polylines."""
    edges = [lo] + [e for door in doors for e in door] + [hi]
    pieces = []
    for a, b in zip(edges[::2], edges[1::2]):
        pieces.append(((a, fixed), (b, fixed)) if horizontal else ((fixed, a), (fixed, b)))
    return tuple(pieces)


_LOOP = World(
    name="loop",
    walls=(
        (
            (0, 0),
            (8, 0),
            (8, -1.5),
            (10, -1.5),
            (10, 0),
            (24, 0),
            (24, 9),
            (25.5, 9),
            (25.5, 11),
            (24, 11),
            (24, 16),
            (14, 16),
            (14, 17.5),
            (12, 17.5),
            (12, 16),
            (0, 16),
            (0, 0),
        ),
        ((4, 4), (15, 4), (15, 4.6), (16.5, 4.6), (16.5, 4), (20, 4), (20, 12), (4, 12), (4, 4)),
        _box(16.0, 0.4, 16.5, 0.9),
        _box(22.8, 5.5, 23.3, 6.0),
        _box(7.0, 15.1, 7.6, 15.6),
        _box(0.4, 7.5, 0.9, 8.0),
    ),
    route=((12.0, 2.0), (22.0, 2.0), (22.0, 14.0), (2.0, 14.0), (2.0, 2.0)),
    corner_radius=1.5,
    description="4 m corridor loop around a 16 m × 8 m block, with alcoves and pillars",
)

_ROOM_DOORS = ((7.5, 8.5), (13.0, 14.0), (18.0, 19.0), (23.5, 24.5))
_ROOMS = World(
    name="rooms",
    walls=(
        _box(0, 0, 32, 22),
        _box(8, 8, 24, 14),
        *_wall_with_doors(5.0, 5.0, 27.0, _ROOM_DOORS, horizontal=True),
        *_wall_with_doors(17.0, 5.0, 27.0, _ROOM_DOORS, horizontal=True),
        *_wall_with_doors(5.0, 5.0, 17.0, ((7.5, 8.5), (13.5, 14.5)), horizontal=False),
        *_wall_with_doors(27.0, 5.0, 17.0, ((7.5, 8.5), (13.5, 14.5)), horizontal=False),
        *(((x, 0), (x, 5)) for x in (11, 16, 21)),
        *(((x, 17), (x, 22)) for x in (11, 16, 21)),
        ((0, 5), (5, 5)),
        ((0, 17), (5, 17)),
        ((27, 5), (32, 5)),
        ((27, 17), (32, 17)),
        ((0, 11), (5, 11)),
        ((27, 11), (32, 11)),
        _box(2.0, 1.5, 4.0, 2.5),
        _box(13.0, 19.0, 14.0, 21.0),
        _box(29.0, 13.0, 31.0, 14.0),
        _box(17.5, 1.0, 19.5, 2.0),
    ),
    route=((16.0, 6.5), (25.5, 6.5), (25.5, 15.5), (6.5, 15.5), (6.5, 6.5)),
    corner_radius=1.2,
    description="office floor: ring corridor around a 16 m × 6 m block, ten rooms behind 1 m doors, furniture",
)

#: the feature kinds of :func:`corridor_loop`, in the order they cycle, and the gaps between feature centres along a side [m]
_FEATURES, _GAPS = ("alcove", "pillar", "recess"), (7.0, 9.0, 8.0)


def corridor_loop(width: float, height: float, name: str | None = None) -> World:
    """The loop world's kind at any size: a 4 m corridor around a block, features every 8 m on average.

    Outer walls the rectangle ``[0, width] × [0, height]``, the block ``[4, width − 4] × [4, height − 4]``, the
    route the corridor's centre line (2 m from the outer walls, corners rounded with radius 1.5 m) from
    ``(width/2, 2)`` heading +x, counter-clockwise. Each side of length L, walked counter-clockwise from its corner,
    has feature centres at u = 6 m and then after gaps cycling 7, 9, 8 m while u ≤ L − 6; the kinds cycle over the
    whole loop: an alcove in the outer wall (2 m wide, 1.5 m deep), a pillar (0.5 m square, 0.4 m off the outer
    wall), a recess in the block wall (1.5 m wide, 0.6 m deep).
    """
    if width < 16 or height < 16:
        raise ValueError(f"corridor_loop needs width and height >= 16 m, got {width} × {height}")
    sides = (
        ((0.0, 0.0), (1.0, 0.0), width),
        ((width, 0.0), (0.0, 1.0), height),
        ((width, height), (-1.0, 0.0), width),
        ((0.0, height), (0.0, -1.0), height),
    )
    outer, block, pillars, kind = [], [], [], 0
    for (ox, oy), (tx, ty), length in sides:
        at = lambda u, v: (ox + u * tx - v * ty, oy + u * ty + v * tx)  # side frame: u along, v inward
        outer.append(at(0.0, 0.0))
        block.append(at(4.0, 4.0))
        u, gap = 6.0, 0
        while u <= length - 6.0:
            what = _FEATURES[kind % 3]
            if what == "alcove":
                outer += [at(u - 1.0, 0.0), at(u - 1.0, -1.5), at(u + 1.0, -1.5), at(u + 1.0, 0.0)]
            elif what == "pillar":
                pillars.append(
                    tuple(
                        at(a, b)
                        for a, b in (
                            (u - 0.25, 0.4),
                            (u + 0.25, 0.4),
                            (u + 0.25, 0.9),
                            (u - 0.25, 0.9),
                            (u - 0.25, 0.4),
                        )
                    )
                )
            else:
                block += [at(u - 0.75, 4.0), at(u - 0.75, 4.6), at(u + 0.75, 4.6), at(u + 0.75, 4.0)]
            kind, u, gap = kind + 1, u + _GAPS[gap % 3], gap + 1
    w2, h2 = width - 2.0, height - 2.0
    return World(
        name=name or f"corridor_loop({width:g}x{height:g})",
        walls=(tuple(outer + outer[:1]), tuple(block + block[:1]), *pillars),
        route=((0.5 * width, 2.0), (w2, 2.0), (w2, h2), (2.0, h2), (2.0, 2.0)),
        corner_radius=1.5,
        description=f"4 m corridor loop around a {width - 8:g} m × {height - 8:g} m block, an alcove, pillar or recess every 8 m",
    )


def pole_field(
    width: float = 60.0, height: float = 40.0, trees: int = 36, beacons: int = 8, inset: float = 8.0, seed: int = 7
) -> World:
    """An open field ``[0, width] × [0, height]`` inside four walls with ``trees`` poles of radius U(0.05, 0.30) m and
    ``beacons`` reflective poles of radius 0.05 m, drawn once from ``seed`` (uniform in the field, rejected closer than
    3 m to another pole, 2.5 m to the route or 1 m to a wall); the route a rectangle ``inset`` from the walls, corners
    rounded with radius 3 m, counter-clockwise from the middle of its bottom side."""
    rng = np.random.default_rng(seed)
    route = (
        (0.5 * width, inset),
        (width - inset, inset),
        (width - inset, height - inset),
        (inset, height - inset),
        (inset, inset),
    )
    legs = np.asarray(route + route[:1], dtype=float)
    poles: list[tuple[float, float, float, bool]] = []
    while len(poles) < trees + beacons:
        p = rng.uniform([1.0, 1.0], [width - 1.0, height - 1.0])
        a, e = legs[:-1], legs[1:] - legs[:-1]
        u = np.clip(np.einsum("ij,ij->i", p - a, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
        if np.min(np.hypot(*(a + u[:, None] * e - p).T)) < 2.5:
            continue
        if any(np.hypot(p[0] - q[0], p[1] - q[1]) < 3.0 for q in poles):
            continue
        beacon = len(poles) >= trees
        radius = 0.05 if beacon else float(rng.uniform(0.05, 0.30))
        poles.append((float(p[0]), float(p[1]), radius, beacon))
    return World(
        name="poles",
        walls=(_box(0.0, 0.0, width, height),),
        route=route,
        corner_radius=3.0,
        description=f"open field {width:g} m × {height:g} m, {trees} tree-like poles and {beacons} reflective beacons",
        poles=tuple(poles),
    )


_CORRIDOR = World(
    name="corridor",
    walls=(_box(0, 0, 80, 12), _box(4, 4, 76, 8)),
    route=((40.0, 2.0), (78.0, 2.0), (78.0, 10.0), (2.0, 10.0), (2.0, 2.0)),
    corner_radius=1.5,
    description="two featureless 4 m × 80 m corridors joined at their ends: along them only the odometry sees motion",
)


def room_corridor(width: float, height: float, aliased: bool, name: str | None = None) -> World:
    """A 4 m corridor ring around a block with a row of 4 m rooms behind its outer wall: perceptual aliasing.

    Corridor, block and route as :func:`corridor_loop` (outer corridor wall ``[0, width] × [0, height]``, block
    ``[4, width − 4] × [4, height − 4]``, the route the centre line from ``(width/2, 2)`` heading +x), the block wall
    plain. Behind the outer wall of each side of length L, walked counter-clockwise from its corner: rooms 4 m wide
    and 3 m deep from u = 6 m while u ≤ L − 6, partitions between them, each room with a 1 m door in the corridor
    wall and a 0.6 m square cabinet. ``aliased``: every room identical (the door at its centre, the cabinet in its
    back right corner), so the corridor repeats every 4 m and only its corners (all alike) break the period — a scan
    fits a place 4 m along as well as its own. Otherwise room j (counted over the whole ring) has its door offset
    by ((3 j) mod 5 − 2) · 0.35 m and its cabinet at ((7 j) mod 5 − 2) · 0.6 m from the centre: the same walls,
    doors and cabinets, each room different (the same drive without aliasing).
    """
    if width < 20 or height < 20:
        raise ValueError(f"room_corridor needs width and height >= 20 m, got {width} × {height}")
    sides = (
        ((0.0, 0.0), (1.0, 0.0), width),
        ((width, 0.0), (0.0, 1.0), height),
        ((width, height), (-1.0, 0.0), width),
        ((0.0, height), (0.0, -1.0), height),
    )
    walls, block, room = [], [], 0
    for (ox, oy), (tx, ty), length in sides:
        at = lambda u, v: (ox + u * tx - v * ty, oy + u * ty + v * tx)  # side frame: u along, v inward
        block.append(at(4.0, 4.0))
        starts = np.arange(6.0, length - 6.0 - 4.0 + 1e-9, 4.0)
        edge = 0.0
        for u in starts:
            door = 0.0 if aliased else ((3 * room) % 5 - 2) * 0.35
            cabinet = 1.2 if aliased else ((7 * room) % 5 - 2) * 0.6
            centre = u + 2.0
            walls.append((at(edge, 0.0), at(centre + door - 0.5, 0.0)))
            edge = centre + door + 0.5
            walls.append((at(u, 0.0), at(u, -3.0)))
            c0, c1 = centre + cabinet - 0.3, centre + cabinet + 0.3
            walls.append((at(c0, -2.9), at(c1, -2.9), at(c1, -2.3), at(c0, -2.3), at(c0, -2.9)))
            room += 1
        if len(starts):
            end = starts[-1] + 4.0
            walls += [(at(end, 0.0), at(end, -3.0)), (at(starts[0], -3.0), at(end, -3.0))]
        walls.append((at(edge, 0.0), at(length, 0.0)))
    w2, h2 = width - 2.0, height - 2.0
    kind = "identical" if aliased else "different"
    return World(
        name=name or f"room_corridor({width:g}x{height:g},{kind})",
        walls=(*walls, tuple(block + block[:1])),
        route=((0.5 * width, 2.0), (w2, 2.0), (w2, h2), (2.0, h2), (2.0, 2.0)),
        corner_radius=1.5,
        description=f"4 m corridor ring around a {width - 8:g} m × {height - 8:g} m block, {kind} 4 m rooms behind its outer wall",
    )


#: world name → World
WORLDS: dict[str, World] = {
    w.name: w
    for w in (
        _LOOP,
        corridor_loop(56.0, 36.0, "long_loop"),
        _ROOMS,
        _CORRIDOR,
        pole_field(),
        room_corridor(56.0, 36.0, aliased=True, name="aliased_rooms"),
        room_corridor(56.0, 36.0, aliased=False, name="distinct_rooms"),
    )
}


def _world(world: str | World) -> World:
    if isinstance(world, World):
        return world
    if world not in WORLDS:
        raise ValueError(f"unknown world {world!r}; choose from {sorted(WORLDS)}")
    return WORLDS[world]


def segments(world: str | World = "loop") -> np.ndarray:
    """The world's walls as ``(S, 4)`` segments ``(x0, y0, x1, y1)`` [m]."""
    rows = []
    for line in _world(world).walls:
        p = np.asarray(line, dtype=float)
        rows.append(np.hstack([p[:-1], p[1:]]))
    return np.vstack(rows)


def raycast(origins: np.ndarray, directions: np.ndarray, walls: np.ndarray, max_range: float = np.inf) -> np.ndarray:
    """Distance along each ray to the nearest wall, ``inf`` when none is hit within ``max_range``.

    ``origins`` (P, 2) sensor positions, ``directions`` (P, B) world angles of the beams,
    ``walls`` (S, 4). Ray ``o + t d`` meets segment ``a + u e`` (``e = b − a``) at
    ``t = (w × e)/(d × e)``, ``u = (w × d)/(d × e)`` with ``w = a − o``; a hit needs ``t > 0``
    and ``0 ≤ u ≤ 1``. Parallel rays never hit. Vectorised over P × B × S in blocks.
    """
    origins = np.asarray(origins, dtype=float).reshape(-1, 2)
    directions = np.asarray(directions, dtype=float).reshape(origins.shape[0], -1)
    walls = np.asarray(walls, dtype=float).reshape(-1, 4)
    P, B = directions.shape
    a, e = walls[:, :2], walls[:, 2:] - walls[:, :2]
    out = np.full((P, B), np.inf)
    block = max(1, _BLOCK_ELEMENTS // max(1, B * walls.shape[0]))
    for lo in range(0, P, block):
        o = origins[lo : lo + block, None, None, :]  # (p, 1, 1, 2)
        dx = np.cos(directions[lo : lo + block])[:, :, None]  # (p, B, 1)
        dy = np.sin(directions[lo : lo + block])[:, :, None]
        wx = a[None, None, :, 0] - o[..., 0]  # (p, 1, S)
        wy = a[None, None, :, 1] - o[..., 1]
        denom = dx * e[:, 1] - dy * e[:, 0]  # d × e, (p, B, S)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (wx * e[:, 1] - wy * e[:, 0]) / denom
            u = (wx * dy - wy * dx) / denom
        hit = (denom != 0) & (t > 0) & (u >= 0) & (u <= 1)
        nearest = np.where(hit, t, np.inf).min(axis=2)
        out[lo : lo + block] = np.where(nearest <= max_range, nearest, np.inf)
    return out


def raycast_poles(origins: np.ndarray, directions: np.ndarray, poles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance along each ray to the nearest pole and that pole's index (``inf`` and −1 where none is hit).

    ``origins`` (P, 2), ``directions`` (P, B) world angles, ``poles`` (C, ≥ 3) rows ``(x, y, radius, …)``. The ray meets
    circle c at ``t = d·w − √((d·w)² − |w|² + ρ²)`` (``w = c − o``) when the root is real and ``t > 0``."""
    origins = np.asarray(origins, dtype=float).reshape(-1, 2)
    directions = np.asarray(directions, dtype=float).reshape(origins.shape[0], -1)
    poles = np.asarray(poles, dtype=float).reshape(-1, 4)
    P, B = directions.shape
    distance, index = np.full((P, B), np.inf), np.full((P, B), -1, dtype=np.int64)
    if poles.shape[0] == 0:
        return distance, index
    block = max(1, _BLOCK_ELEMENTS // max(1, B * poles.shape[0]))
    for lo in range(0, P, block):
        o, d = origins[lo : lo + block], directions[lo : lo + block]
        wx = poles[None, None, :, 0] - o[:, None, None, 0]  # (p, 1, C)
        wy = poles[None, None, :, 1] - o[:, None, None, 1]
        dw = np.cos(d)[:, :, None] * wx + np.sin(d)[:, :, None] * wy  # (p, B, C)
        disc = dw**2 - (wx**2 + wy**2) + poles[:, 2] ** 2
        with np.errstate(invalid="ignore"):
            t = dw - np.sqrt(disc)
        t = np.where((disc >= 0) & (t > 0), t, np.inf)
        nearest = t.argmin(axis=2)
        distance[lo : lo + block] = np.take_along_axis(t, nearest[:, :, None], axis=2)[:, :, 0]
        index[lo : lo + block] = np.where(np.isfinite(distance[lo : lo + block]), nearest, -1)
    return distance, index


def true_occupancy(
    resolution: float, world: str | World = "loop", origin=None, shape=None, margin: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """The walls rasterised: a boolean grid ``occupied[iy, ix]`` and its ``origin`` (2,).

    Conventions of :mod:`slamarena.mapping.occupancy_grid`: ``origin`` is the lower-left corner of cell
    (0, 0), cell ``(ix, iy)`` covers ``origin + [i, i + 1)·resolution``. A cell is occupied when
    a wall segment meets its closed square (so a wall lying exactly on a cell border marks
    the cells on both sides). Default grid: the walls' bounding box plus ``margin``, with the
    origin shifted half a cell so that cell centres fall on multiples of ``resolution`` (walls
    on round coordinates then run through cell centres, one cell thick). Give ``origin`` and
    ``shape = (ny, nx)`` to rasterise onto an estimated map's grid.
    """
    if not resolution > 0:
        raise ValueError("resolution must be > 0")
    walls = segments(world)
    if origin is None:
        lo = walls.reshape(-1, 2).min(axis=0) - margin
        origin = (np.floor(lo / resolution) - 0.5) * resolution
    origin = np.asarray(origin, dtype=float).reshape(2)
    if shape is None:
        hi = walls.reshape(-1, 2).max(axis=0) + margin
        nx, ny = (np.ceil((hi - origin) / resolution)).astype(int) + 1
        shape = (int(ny), int(nx))
    ny, nx = shape
    grid = np.zeros((ny, nx), dtype=bool)
    for x0, y0, x1, y1 in walls:
        i_lo = np.floor((np.minimum([x0, y0], [x1, y1]) - origin) / resolution).astype(int) - 1
        i_hi = np.floor((np.maximum([x0, y0], [x1, y1]) - origin) / resolution).astype(int) + 1
        i_lo = np.maximum(i_lo, 0)
        i_hi = np.minimum(i_hi, [nx - 1, ny - 1])
        if np.any(i_hi < i_lo):
            continue
        ix, iy = np.meshgrid(np.arange(i_lo[0], i_hi[0] + 1), np.arange(i_lo[1], i_hi[1] + 1))
        cx0 = origin[0] + ix * resolution
        cy0 = origin[1] + iy * resolution
        grid[iy, ix] |= _segment_meets_box(x0, y0, x1, y1, cx0, cy0, cx0 + resolution, cy0 + resolution)
    return grid, origin


def _segment_meets_box(x0, y0, x1, y1, bx0, by0, bx1, by1) -> np.ndarray:
    """Whether segment (x0, y0)–(x1, y1) meets the closed boxes [bx0, bx1] × [by0, by1] (Liang–Barsky)."""
    t_in = np.zeros(np.shape(bx0))
    t_out = np.ones(np.shape(bx0))
    ok = np.ones(np.shape(bx0), dtype=bool)
    for p0, d, lo, hi in ((x0, x1 - x0, bx0, bx1), (y0, y1 - y0, by0, by1)):
        if d == 0:
            ok &= (p0 >= lo) & (p0 <= hi)
            continue
        ta, tb = (lo - p0) / d, (hi - p0) / d
        t_in = np.maximum(t_in, np.minimum(ta, tb))
        t_out = np.minimum(t_out, np.maximum(ta, tb))
    return ok & (t_in <= t_out)


def route_controls(world: str | World, speed: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True (v, ω) of one lap of the world's route and the start pose (see the module docstring)."""
    w = _world(world)
    p = np.asarray(w.route, dtype=float)
    heading = np.arctan2(*(np.roll(p, -1, axis=0) - p)[:, ::-1].T)  # of the leg leaving waypoint i
    length = np.hypot(*(np.roll(p, -1, axis=0) - p).T)
    turn = wrap_angle(heading - np.roll(heading, 1))  # at waypoint i
    if abs(turn[0]) > 1e-12:
        raise ValueError(f"world {w.name!r}: the route must start on a straight (no turn at its first waypoint)")
    tangent = w.corner_radius * np.tan(0.5 * np.abs(turn))
    v, omega = [], []
    for i in range(len(p)):
        straight = length[i] - tangent[i] - tangent[(i + 1) % len(p)]
        if straight < -1e-9:
            raise ValueError(f"world {w.name!r}: leg {i} is too short for corner radius {w.corner_radius}")
        if straight > 1e-9:
            n = max(1, int(round(straight / (speed * dt))))
            v += [straight / (n * dt)] * n
            omega += [0.0] * n
        alpha = turn[(i + 1) % len(p)]
        if abs(alpha) > 1e-12:
            n = max(1, int(round(w.corner_radius * abs(alpha) / (speed * dt))))
            rate = alpha / (n * dt)
            v += [abs(rate) * w.corner_radius] * n
            omega += [rate] * n
    return np.asarray(v), np.asarray(omega), np.array([p[0, 0], p[0, 1], heading[0]])


def _beam_angles(n_beams: int, fov: float) -> np.ndarray:
    if fov >= 2.0 * math.pi - 1e-12:
        return -math.pi + 2.0 * math.pi * np.arange(n_beams) / n_beams
    return np.linspace(-0.5 * fov, 0.5 * fov, n_beams)


class LaserWorldParams(Params):
    """Parameters of :func:`simulate` (metres, radians, seconds, Hz; the model is in the module docstring)."""

    model_config = ConfigDict(allow_inf_nan=False)

    world: Literal["loop", "long_loop", "rooms", "corridor", "poles", "aliased_rooms", "distinct_rooms"] | World = (
        Field("loop", description="a world of WORLDS by name, or a World")
    )
    n_beams: int = Field(361, ge=1, description="beams per scan")
    fov: float = Field(1.5 * math.pi, gt=0, le=2 * math.pi, description="field of view of a scan, centred ahead [rad]")
    max_range: float = Field(12.0, gt=0, description="sensor range; the reading of a beam without return [m]")
    sigma_range: float = Field(0.01, ge=0, description="std of the range noise [m]")
    dropout: float = Field(0.0, ge=0, lt=1, description="probability that a beam drops out (reads max_range)")
    mount: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="sensor pose in the robot frame (x [m], y [m], θ [rad])"
    )
    speed: float = Field(0.5, gt=0, description="speed along the route [m/s]")
    laps: int = Field(1, ge=1, description="laps of the route")
    odom_rate: float = Field(20.0, gt=0, description="odometry rate 1/dt [Hz]")
    scan_rate: float = Field(5.0, gt=0, description="scan rate [Hz]; odom_rate / scan_rate must be a whole number")
    k_t: float = Field(0.02, ge=0, description="odometry noise along the motion [m/√m]")
    k_s: float = Field(0.01, ge=0, description="odometry noise across the motion [m/√m]")
    k_r: float = Field(0.03, ge=0, description="heading noise per turn [rad/√rad]")
    k_rt: float = Field(0.01, ge=0, description="heading noise per distance [rad/√m]")
    t0: float = Field(0.0, description="first stamp [s]")
    seed: int = Field(0, ge=0, description="seed of numpy.random.SeedSequence (odometry, range noise, dropouts)")

    @model_validator(mode="after")
    def _scans_at_odometry_stamps(self):
        ratio = self.odom_rate / self.scan_rate
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(f"odom_rate / scan_rate must be a whole number >= 1, got {ratio!r}")
        return self

    @model_validator(mode="after")
    def _fits_in_memory(self):
        """The run's arrays must fit in the memory available (:func:`slamarena.resources.require_memory`): K = laps ×
        (the route polygon's length, an upper bound of the driven lap's) / (speed / odom_rate) odometry rows (≈ 200 B
        each: increments, their covariance, truth, odometry) and K / (odom_rate / scan_rate) scans of n_beams beams
        (32 B a beam: true and noisy ranges, dropouts)."""
        route = np.asarray(_world(self.world).route, dtype=float)
        lap = float(np.hypot(*(np.roll(route, -1, axis=0) - route).T).sum())
        steps = self.laps * lap / self.speed * self.odom_rate
        scans = steps * self.scan_rate / self.odom_rate
        require_memory(
            steps * 200.0 + scans * self.n_beams * 32.0,
            f"laps = {self.laps}, odom_rate = {self.odom_rate:g} Hz, scan_rate = {self.scan_rate:g} Hz, "
            f"n_beams = {self.n_beams} make a run of {steps:.3g} odometry rows and {scans:.3g} scans",
        )
        return self


@with_params(LaserWorldParams)
def simulate(*, params: LaserWorldParams) -> Sequence:
    """Simulate one run of the laser world (:class:`LaserWorldParams`; the model is in the module docstring)."""
    p = params
    w = _world(p.world)
    every = int(round(p.odom_rate / p.scan_rate))
    mount = np.asarray(p.mount, dtype=float)

    rng_odom, rng_range, rng_dropout = (np.random.default_rng(s) for s in np.random.SeedSequence(p.seed).spawn(3))

    # ---------------------------------------------------------------- truth and odometry
    dt = 1.0 / p.odom_rate
    v_lap, w_lap, start = route_controls(w, p.speed, dt)
    v, omega = np.tile(v_lap, p.laps), np.tile(w_lap, p.laps)
    K = v.size
    t = p.t0 + dt * np.arange(K + 1)
    delta = kinematics.increment("arc", v, omega, dt)
    truth = accumulate(start, delta)
    ds, dth = np.abs(v) * dt, np.abs(omega) * dt
    var = np.column_stack([p.k_t**2 * ds, p.k_s**2 * ds, p.k_r**2 * dth + p.k_rt**2 * ds]) + 1e-12
    cov = np.zeros((K, 3, 3))
    cov[:, [0, 1, 2], [0, 1, 2]] = var
    noisy = delta + np.sqrt(var) * rng_odom.standard_normal((K, 3))
    odometry = accumulate(start, noisy)

    # ---------------------------------------------------------------- scans
    k_scan = np.arange(0, K + 1, every)
    angles = _beam_angles(p.n_beams, p.fov)
    sensor = compose(truth[k_scan], mount)
    directions = sensor[:, 2:3] + angles[None, :]
    true_ranges = raycast(sensor[:, :2], directions, segments(w), p.max_range)
    poles = np.asarray(w.poles, dtype=float).reshape(-1, 4)
    intensities = None
    if len(poles):
        to_pole, pole = raycast_poles(sensor[:, :2], directions, poles)
        first = (to_pole < true_ranges) & (to_pole <= p.max_range)
        true_ranges = np.where(first, to_pole, true_ranges)
        if poles[:, 3].any():
            intensities = (first & (poles[np.maximum(pole, 0), 3] > 0)).astype(np.float32)
    ranges = true_ranges + p.sigma_range * rng_range.standard_normal(true_ranges.shape)
    dropped = rng_dropout.uniform(size=ranges.shape) < p.dropout
    no_return = ~np.isfinite(true_ranges) | (ranges >= p.max_range) | dropped
    ranges[no_return] = p.max_range
    if intensities is not None:
        intensities[no_return] = 0.0

    meta = dict(
        dataset="sim:laser",
        **{**p.canonical(), "world": w.name},
        world_description=w.description,
        steps_per_lap=int(v_lap.size),
        route_length=float(np.sum(np.abs(v_lap)) * dt),
        no_return_fraction=float(np.mean(ranges >= p.max_range)),
        dropped_beams=int(dropped.sum()),
    )
    landmarks = None
    if len(poles):
        landmarks = LandmarkMap(ids=np.arange(len(poles)), xy=poles[:, :2])
        meta.update(pole_radius=poles[:, 2].tolist(), pole_reflective=(poles[:, 3] > 0).tolist())
    return Sequence(
        name=f"sim:laser({w.name},seed={p.seed})",
        motion=Increments(t=t[1:], delta=noisy, cov=cov),
        scans=Scans(
            t=t[k_scan],
            ranges=ranges,
            angles=angles,
            max_range=p.max_range,
            mount=mount,
            pose=odometry[k_scan],
            intensities=intensities,
        ),
        ground_truth=Trajectory(t=t, poses=truth),
        landmarks=landmarks,
        initial_pose=start,
        noise=Noise(),
        meta=meta,
    )
