"""sim:laser — analytic scans of a known world, max-range and dropout, odometry noise, closure, occupancy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from checks import assert_gaussian, assert_rejected_naming
from scipy import stats

from slamarena import datasets
from slamarena.datasets.geometry import accumulate, between, compose, transform_points
from slamarena.datasets.sim.laser import (
    WORLDS,
    LaserWorldParams,
    World,
    corridor_loop,
    raycast,
    room_corridor,
    route_controls,
    segments,
    simulate,
    true_occupancy,
)

BOX = World(
    name="box",
    walls=(((-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0), (-5.0, -5.0)),),
    route=((0.0, -2.0), (2.0, -2.0), (2.0, 2.0), (-2.0, 2.0), (-2.0, -2.0)),
    corner_radius=0.5,
    description="a 10 m square room",
)


def box_ranges(pose: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Distance from inside the 10 m box to its walls along world angles pose[2] + angles."""
    c, s = np.cos(pose[2] + angles), np.sin(pose[2] + angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (5.0 - pose[0]) / c, np.where(c < 0, (-5.0 - pose[0]) / c, np.inf))
        ty = np.where(s > 0, (5.0 - pose[1]) / s, np.where(s < 0, (-5.0 - pose[1]) / s, np.inf))
    return np.minimum(tx, ty)


@pytest.mark.parametrize("mount", [(0.0, 0.0, 0.0), (0.3, 0.1, 0.2)])
def test_scans_of_a_box_equal_the_analytic_ranges(mount):
    s = simulate(world=BOX, sigma_range=0.0, max_range=20.0, fov=2 * math.pi, n_beams=360, mount=mount)
    for j in (0, len(s.scans) // 3, len(s.scans) - 1):
        k = np.searchsorted(s.ground_truth.t, s.scans.t[j])
        sensor = compose(s.ground_truth.poses[k], np.asarray(mount))
        np.testing.assert_allclose(s.scans.ranges[j], box_ranges(sensor, s.scans.angles), rtol=1e-9)


def test_max_range_readings():
    s = simulate(world=BOX, sigma_range=0.0, max_range=4.0, fov=2 * math.pi, n_beams=720)
    k = np.searchsorted(s.ground_truth.t, s.scans.t)
    expected = np.stack([box_ranges(s.ground_truth.poses[i], s.scans.angles) for i in k])
    beyond = expected > 4.0
    assert 0.2 < beyond.mean() < 0.95
    np.testing.assert_array_equal(s.scans.ranges[beyond], 4.0)
    np.testing.assert_allclose(s.scans.ranges[~beyond], expected[~beyond], rtol=1e-9)
    assert s.scans.max_range == 4.0


def test_beam_angles_and_fov():
    s = simulate(world=BOX, n_beams=181, fov=math.pi)
    np.testing.assert_allclose(s.scans.angles[[0, 90, 180]], [-math.pi / 2, 0.0, math.pi / 2])
    full = simulate(world=BOX, n_beams=4, fov=2 * math.pi)
    np.testing.assert_allclose(full.scans.angles, [-math.pi, -math.pi / 2, 0.0, math.pi / 2])


def test_range_noise_and_dropout_statistics():
    s = simulate(world="loop", sigma_range=0.02, dropout=0.05, seed=3)
    clean = simulate(world="loop", sigma_range=0.0, seed=3)
    hit = clean.scans.ranges < 11.5
    changed = s.scans.ranges != clean.scans.ranges
    dropped = hit & (s.scans.ranges == s.scans.max_range)
    n = hit.sum()
    assert stats.binom.ppf(1e-4, n, 0.05) <= dropped.sum() <= stats.binom.ppf(1 - 1e-4, n, 0.05)
    keep = hit & ~dropped
    assert changed[keep].all()
    assert_gaussian(s.scans.ranges[keep] - clean.scans.ranges[keep], 0.02)


def test_odometry_noise_has_the_stated_covariance():
    s = simulate(world="rooms", seed=4, laps=2)
    inc = s.motion
    true = between(s.ground_truth.poses[:-1], s.ground_truth.poses[1:])
    z = (inc.delta - true) / np.sqrt(np.diagonal(inc.cov, axis1=1, axis2=2))
    for c in range(3):
        assert_gaussian(z[:, c], 1.0)
    np.testing.assert_allclose(inc.t, s.ground_truth.t[1:])


def test_scan_pose_is_the_odometry_pose():
    s = simulate(world="loop", seed=5)
    odometry = accumulate(s.initial_pose, s.motion.delta)
    k = np.searchsorted(s.ground_truth.t, s.scans.t)
    np.testing.assert_allclose(s.scans.pose, odometry[k], atol=1e-12)
    assert s.scans.t[0] == s.ground_truth.t[0]
    np.testing.assert_allclose(np.diff(s.scans.t), 0.2)
    assert np.linalg.norm(s.scans.pose[-1, :2] - s.ground_truth.poses[-1, :2]) > 0.01  # odometry drifts


@pytest.mark.parametrize("world", sorted(WORLDS))
def test_route_closes_every_lap_and_stays_clear_of_walls(world):
    s = simulate(world=world, laps=2, n_beams=8)
    gt = s.ground_truth.poses
    per_lap = s.meta["steps_per_lap"]
    np.testing.assert_allclose(gt[per_lap], gt[0], atol=1e-9)
    np.testing.assert_allclose(gt[-1], gt[0], atol=1e-9)
    around = raycast(gt[::5, :2], gt[::5, 2:3] + np.linspace(-np.pi, np.pi, 72, endpoint=False), segments(world))
    assert around.min() > 0.5


def test_long_loop_walls_are_where_the_docstring_says():
    """``long_loop``: from the route's straights the beams square to the track see the block 2 m to the left (2.6 m
    in a recess) and the outer wall 2 m to the right (3.5 m in an alcove, 1.1 m at a pillar): a 4 m corridor between
    the rectangles [0, 56] × [0, 36] and [4, 52] × [4, 32]; 20 features on the 168 m rectangle (one per 8.4 m), in
    the cycle alcove, pillar, recess."""
    s = simulate(world="long_loop", n_beams=8)
    gt = s.ground_truth.poses
    np.testing.assert_allclose(gt[0], [28.0, 2.0, 0.0])
    assert s.meta["route_length"] == pytest.approx(2 * (52 + 32) - 4 * (2 - math.pi / 2) * 1.5)
    u = np.arange(5.1, 51.0, 0.5)  # off every feature edge (whole, quarter and three-quarter metres)
    v = u[u < 31.0]
    straight = np.vstack(
        [
            np.column_stack([u, np.full_like(u, 2.0), np.zeros_like(u)]),
            np.column_stack([np.full_like(v, 54.0), v, np.full_like(v, np.pi / 2)]),
            np.column_stack([u, np.full_like(u, 34.0), np.full_like(u, np.pi)]),
            np.column_stack([np.full_like(v, 2.0), v, np.full_like(v, -np.pi / 2)]),
        ]
    )
    on_route = np.abs(gt[:, None, :2] - straight[None, :, :2]).sum(axis=2).min(axis=0)
    assert on_route.max() < 0.02  # the route runs along these lines (poses every 2.5 cm)
    left, right = raycast(
        straight[:, :2], straight[:, 2:3] + np.array([[np.pi / 2, -np.pi / 2]]), segments("long_loop")
    ).T
    assert set(np.round(left, 9)) == {2.0, 2.6} and set(np.round(right, 9)) == {1.1, 2.0, 3.5}
    assert np.mean((np.round(left, 9) == 2.0) & (np.round(right, 9) == 2.0)) > 0.7
    walls = segments("long_loop")
    assert np.allclose(walls.reshape(-1, 2).min(axis=0), -1.5) and np.allclose(
        walls.reshape(-1, 2).max(axis=0), [57.5, 37.5]
    )
    world = WORLDS["long_loop"]
    alcoves, recesses, pillars = (len(world.walls[0]) - 5) // 4, (len(world.walls[1]) - 5) // 4, len(world.walls) - 2
    assert (alcoves, pillars, recesses) == (7, 7, 6)


def test_a_corridor_loop_smaller_than_its_corridors_is_refused():
    with pytest.raises(ValueError, match="16 m"):
        corridor_loop(12.0, 30.0)


def test_route_speed():
    v, w, start = route_controls("loop", speed=0.5, dt=0.05)
    assert np.all(np.abs(v - 0.5) < 0.05)
    assert start[2] == 0.0 and np.isclose(np.sum(w) * 0.05, 2 * math.pi)


def test_raycast_equals_a_literal_loop(rng):
    walls = rng.uniform(-5, 5, (25, 4))
    origins = rng.uniform(-3, 3, (6, 2))
    directions = rng.uniform(-np.pi, np.pi, (6, 40))
    fast = raycast(origins, directions, walls, max_range=6.0)
    for p in range(6):
        for b in range(40):
            d = np.array([math.cos(directions[p, b]), math.sin(directions[p, b])])
            best = math.inf
            for x0, y0, x1, y1 in walls:
                e = np.array([x1 - x0, y1 - y0])
                M = np.column_stack([d, -e])
                if abs(np.linalg.det(M)) < 1e-12:
                    continue
                t, u = np.linalg.solve(M, np.array([x0, y0]) - origins[p])
                if t > 0 and 0 <= u <= 1:
                    best = min(best, t)
            expected = best if best <= 6.0 else math.inf
            assert fast[p, b] == pytest.approx(expected, rel=1e-9)


def test_true_occupancy_of_the_box():
    grid, origin = true_occupancy(0.1, BOX)
    np.testing.assert_allclose(origin, [-6.05, -6.05])
    assert grid.sum() == 4 * 100  # one-cell-thick walls through cell centres
    centres = origin + (np.argwhere(grid)[:, ::-1] + 0.5) * 0.1
    assert np.all(np.isclose(np.abs(centres).max(axis=1), 5.0))
    aligned, _ = true_occupancy(0.1, BOX, origin=(-6.0, -6.0), shape=(120, 120))
    assert aligned.sum() == 4 * 2 * 102 - 4 * 4  # walls on cell borders mark both sides; 2 × 2 corner blocks shared


def test_scan_end_points_fall_in_occupied_cells():
    s = simulate(world="rooms", sigma_range=0.0, seed=1)
    grid, origin = true_occupancy(0.05, "rooms")
    k = np.searchsorted(s.ground_truth.t, s.scans.t)
    for j in range(0, len(s.scans), 37):
        r = s.scans.ranges[j]
        hit = r < s.scans.max_range
        local = np.column_stack([r * np.cos(s.scans.angles), r * np.sin(s.scans.angles)])[hit]
        pts = transform_points(s.ground_truth.poses[k[j]], local)
        ij = np.floor((pts - origin) / 0.05).astype(int)
        assert grid[ij[:, 1], ij[:, 0]].all()


def test_registry_and_determinism():
    a = datasets.load("sim:laser", world="rooms", n_beams=31, seed=9)
    b = simulate(world="rooms", n_beams=31, seed=9)
    np.testing.assert_array_equal(a.scans.ranges, b.scans.ranges)
    np.testing.assert_array_equal(a.motion.delta, b.motion.delta)
    assert not np.array_equal(a.motion.delta, simulate(world="rooms", n_beams=31, seed=10).motion.delta)


@pytest.mark.parametrize(
    "bad",
    [
        dict(world="maze"),
        dict(fov=7.0),
        dict(dropout=1.0),
        dict(scan_rate=3.0),
        dict(n_beams=0),
        dict(sigma_range=-0.1),
        dict(max_range=0.0),
        dict(max_range=float("nan")),
        dict(mount=(0.0, 0.0)),
        dict(seed=-1),
        dict(nbeams=8),
        dict(laps=10**9),  # a run beyond the memory available
        dict(n_beams=10**9),
    ],
)
def test_bad_config_is_rejected_naming_the_field(bad):
    assert_rejected_naming(simulate, **bad)


def test_a_params_model_and_keywords_simulate_alike():
    given = simulate(params=LaserWorldParams(world=BOX, n_beams=16, mount=(0.2, 0.0, 0.1), seed=2))
    keywords = datasets.load("sim:laser", world=BOX, n_beams=16, mount=(0.2, 0.0, 0.1), seed=2)
    assert simulate.Params is LaserWorldParams and given.meta == keywords.meta and given.meta["world"] == "box"
    np.testing.assert_array_equal(given.scans.ranges, keywords.scans.ranges)


def test_pole_rays_meet_the_nearest_circle_first():
    """raycast_poles against the geometry: the hit lies on its circle, no point of the ray before it is inside any
    circle, and a ray that hits nothing passes outside every circle; a head-on ray meets a pole at d − ρ."""
    from slamarena.datasets.sim.laser import raycast_poles

    rng = np.random.default_rng(8)
    poles = np.column_stack([rng.uniform(-10, 10, (12, 2)), rng.uniform(0.1, 1.0, 12), np.zeros(12)])
    origins = rng.uniform(-12, 12, (30, 2))
    inside = np.hypot(origins[:, None, 0] - poles[:, 0], origins[:, None, 1] - poles[:, 1]) < poles[:, 2]
    origins = origins[~inside.any(axis=1)]
    directions = rng.uniform(-np.pi, np.pi, (len(origins), 40))
    t, index = raycast_poles(origins, directions, poles)
    d = np.stack([np.cos(directions), np.sin(directions)], -1)
    samples = np.linspace(0, 1, 400)
    for p in range(len(origins)):
        for b in range(directions.shape[1]):
            reach = t[p, b] if np.isfinite(t[p, b]) else 40.0
            pts = origins[p] + (samples[:, None] * reach) * d[p, b]
            gap = np.hypot(pts[:, None, 0] - poles[:, 0], pts[:, None, 1] - poles[:, 1]) - poles[:, 2]
            assert gap[:-1].min() > -1e-9  # nothing inside a circle before the hit
            if np.isfinite(t[p, b]):
                assert abs(gap[-1, index[p, b]]) < 1e-9
    head_on, which = raycast_poles(np.zeros((1, 2)), np.zeros((1, 1)), np.array([[5.0, 0.0, 0.5, 1.0]]))
    assert head_on[0, 0] == pytest.approx(4.5) and which[0, 0] == 0


def test_the_pole_field_gives_intensities_and_its_poles_as_landmarks():
    seq = datasets.load("sim:laser", world="poles", fov=np.pi, n_beams=181, max_range=30.0, laps=1, seed=3)
    poles = np.asarray(WORLDS["poles"].poles)
    assert len(seq.landmarks) == len(poles) == 44 and np.allclose(seq.landmarks.xy, poles[:, :2])
    assert seq.meta["pole_reflective"].count(True) == 8
    bright = seq.scans.intensities > 0
    assert bright.any() and np.all(seq.scans.ranges[bright] < 30.0)
    assert set(np.unique(seq.scans.intensities)) <= {0.0, 1.0}
    assert datasets.load("sim:laser", n_beams=16, seed=0).scans.intensities is None  # no reflective poles: none


def test_aliased_rooms_look_the_same_4_m_along_and_distinct_rooms_do_not():
    """Perceptual aliasing: from the bottom corridor's centre line, an 8 m scan at x and at x + 4 m reads the same
    ranges in ``aliased_rooms`` (identical rooms every 4 m) and not in ``distinct_rooms`` (each room's door and
    cabinet shifted differently); both share the ring, its route and the number of rooms."""
    angles = np.linspace(-0.75 * np.pi, 0.75 * np.pi, 271)
    origins = np.array([[18.0, 2.0], [22.0, 2.0], [30.0, 2.0]])
    for world, same in (("aliased_rooms", True), ("distinct_rooms", False)):
        r = raycast(origins, np.broadcast_to(angles, (3, angles.size)), segments(world), max_range=8.0)
        seen_into_rooms = np.isfinite(r[0]) & (r[0] * np.sin(-angles) > 2.5)  # beams through a door
        assert seen_into_rooms.any()
        for other in (1, 2):
            assert np.allclose(r[0], r[other], rtol=0, atol=1e-9, equal_nan=True) == same, (world, other)
    a, d = WORLDS["aliased_rooms"], WORLDS["distinct_rooms"]
    assert a.route == d.route == WORLDS["long_loop"].route and len(a.walls) == len(d.walls)
    with pytest.raises(ValueError, match="20 m"):
        room_corridor(12.0, 30.0, aliased=True)
