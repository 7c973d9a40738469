"""Occupancy grid: Bayes update after known hit/miss sequences, conventions, export round trip."""

from __future__ import annotations

import re

import numpy as np
import pytest
from pydantic import ValidationError

from slamarena.mapping.map_pyramid import MapPyramid
from slamarena.mapping.occupancy_grid import CellModelParams, OccupancyGrid, load_map_server, logit, probability

RES = 0.1


def grid(grow=True, **cells):
    cells.setdefault("clamp", None)
    return OccupancyGrid(
        resolution=RES, width=41, height=41, origin=(-2.05, -2.05), grow=grow, cells=cells
    )  # cell centres on multiples of 0.1 m


def cell_p(g, x, y):
    ix, iy = g.world_to_grid([x, y])
    return float(g.probability()[iy, ix])


BEAM = dict(angles=[0.0], pose=[0.0, 0.0, 0.0], max_range=10.0)


def test_known_hit_miss_sequence():
    g = grid()
    for r in (1.0, 1.0, 0.5, 1.0):  # the cell at x = 0.5 is passed 3 times and hit once
        g.integrate([r], **BEAM)
    l_hit, l_miss = logit(0.7), logit(0.4)
    assert cell_p(g, 1.0, 0.0) == pytest.approx(probability(3 * l_hit), abs=1e-6)
    assert cell_p(g, 0.5, 0.0) == pytest.approx(probability(l_hit + 3 * l_miss), abs=1e-6)
    assert cell_p(g, 0.2, 0.0) == pytest.approx(probability(4 * l_miss), abs=1e-6)
    assert cell_p(g, 0.8, 0.0) == pytest.approx(probability(3 * l_miss), abs=1e-6)
    assert cell_p(g, 1.1, 0.0) == pytest.approx(0.5)  # beyond the hit: untouched
    ros = g.to_ros()
    ix, iy = g.world_to_grid([[1.0, 0.0], [0.2, 0.0], [1.1, 0.0], [0.5, 0.0]]).T
    # p(1.0) = 0.93 occupied, p(0.2) = 0.165 free, untouched unknown, p(0.5) = 0.41 unknown
    assert ros[iy, ix].tolist() == [100, 0, -1, -1]


def test_posterior_with_a_non_uniform_prior_needs_the_l0_term():
    """One hit must give p(m | z) = p_hit whatever the prior (the inverse sensor model).

    The notes' update ``l += logit(p)`` (no ``− l0``) fails this for p_prior ≠ 0.5.
    """
    g = grid(p_prior=0.45)
    g.integrate([1.0], **BEAM)
    assert cell_p(g, 1.0, 0.0) == pytest.approx(0.7, abs=1e-6)
    assert cell_p(g, 0.5, 0.0) == pytest.approx(0.4, abs=1e-6)
    notes_form = probability(logit(0.45) + logit(0.7))
    assert abs(notes_form - 0.7) > 0.04


def test_each_cell_updated_once_per_scan_and_hit_wins_over_free():
    g = grid()
    # beam 0 and 1 end in the same cell; beam 2 passes through the cell beam 3 ends in
    ranges = [1.0, 1.02, 1.5, 0.5]
    angles = [0.0, 0.01, 0.0, 0.0]
    n = g.integrate(ranges, angles, [0.0, 0.0, 0.0], max_range=10.0)
    assert cell_p(g, 1.0, 0.0) == pytest.approx(0.7, abs=1e-6)
    assert cell_p(g, 0.5, 0.0) == pytest.approx(0.7, abs=1e-6)
    assert cell_p(g, 0.2, 0.0) == pytest.approx(0.4, abs=1e-6)
    assert cell_p(g, 1.5, 0.0) == pytest.approx(0.7, abs=1e-6)
    assert n == 16  # cells 0.0 … 1.5 along x at 0.1 m: each counted once


def test_max_range_clears_without_hit_and_bad_readings_are_ignored():
    g = grid()
    g.integrate(
        [10.0, np.nan, np.inf, 0.0, -1.0], [0.0, 0.5, 1.0, 1.5, 2.0], [0.0, 0.0, 0.0], max_range=10.0, clear_range=1.0
    )
    assert cell_p(g, 1.0, 0.0) == pytest.approx(0.4, abs=1e-6)  # end of the clearing ray: free, no hit
    assert cell_p(g, 1.2, 0.0) == pytest.approx(0.5)
    assert (np.abs(g.log_odds - g.l0) > 0).sum() == 11  # only the one cleared ray


def test_clamping_lets_a_cell_change_its_mind():
    def misses_to_free(clamp):
        g = grid(clamp=clamp)
        for _ in range(50):
            g.integrate([1.0], **BEAM)
        for k in range(1, 200):  # the obstacle left: beams now pass through it
            g.integrate([1.5], **BEAM)
            if cell_p(g, 1.0, 0.0) < 0.25:
                return k, g

    k, g = misses_to_free((0.12, 0.97))
    assert k == int(np.ceil((logit(0.97) - logit(0.25)) / -logit(0.4)))  # 12
    assert cell_p(g, 0.5, 0.0) == pytest.approx(0.12, abs=1e-6)
    assert misses_to_free(None)[0] > 100


def test_sensor_mounting_pose_is_honoured():
    g = grid()
    g.integrate([1.0], [0.0], pose=[0.0, 0.0, np.pi / 2], mount=[0.3, 0.0, -np.pi / 2], max_range=10.0)
    # sensor at (0, 0.3) facing +x: the hit is at (1.0, 0.3)
    assert cell_p(g, 1.0, 0.3) == pytest.approx(0.7, abs=1e-6)
    assert cell_p(g, 0.5, 0.3) == pytest.approx(0.4, abs=1e-6)
    assert cell_p(g, 0.5, 0.0) == pytest.approx(0.5)


def test_world_to_grid_rounds_with_the_half_cell_shift():
    g = grid()
    centres = g.grid_to_world(np.array([[0, 0], [19, 20], [39, 39]]))
    assert np.allclose(centres, [[-2.0, -2.0], [-0.1, 0.0], [1.9, 1.9]])
    # every point within half a cell of a centre maps to that cell, on both sides of 0
    for ij, c in zip([[0, 0], [19, 20], [39, 39]], centres):
        for d in (-0.049, 0.0, 0.049):
            assert g.world_to_grid(c + d).tolist() == ij
    # the notes' formula taken literally, int((w − origin)/res) with origin = centre of cell 0,
    # truncates: a point 0.04 m left of the centre of cell 20 (x = 0) lands in cell 19
    o_centre = g.origin + 0.5 * RES
    notes = np.trunc((np.array([-0.04, 0.0]) - o_centre) / RES).astype(int)
    assert g.world_to_grid([-0.04, 0.0])[0] == 20 and notes[0] == 19


def test_growing_keeps_cells_at_their_world_position():
    g = OccupancyGrid(resolution=RES, width=10, height=10, origin=(-0.05, -0.05), cells={"clamp": None})
    g.integrate([0.3], [0.0], [0.5, 0.5, 0.0], max_range=10.0)
    before = g.world_to_grid([0.8, 0.5])
    assert g.probability()[before[1], before[0]] == pytest.approx(0.7)
    g.integrate([3.0], [np.pi], [0.5, 0.5, 0.0], max_range=10.0)  # reaches x = -2.5
    assert g.origin[0] < -2.5 and g.shape == (10, 10 + 64)
    assert cell_p(g, 0.8, 0.5) == pytest.approx(0.7) and cell_p(g, -2.5, 0.5) == pytest.approx(0.7)


def test_map_server_round_trip(tmp_path):
    g = grid()
    rng = np.random.default_rng(0)
    for _ in range(5):
        g.integrate(
            rng.uniform(0.5, 1.8, 90), np.linspace(-np.pi, np.pi, 90, endpoint=False), [0.1, -0.2, 0.3], max_range=1.7
        )
    ros = g.to_ros()
    assert set(np.unique(ros)) == {-1, 0, 100}
    pgm, yml = g.save_map_server(tmp_path / "map")
    back, res, origin = load_map_server(yml)
    assert np.array_equal(back, ros) and res == RES and np.allclose(origin, g.origin)
    # with the grid's own free threshold (0.25) in the YAML, map_server would read unknown grey as free
    import yaml

    meta = yaml.safe_load(yml.read_text())
    meta["free_thresh"] = 0.25
    yml.write_text(yaml.safe_dump(meta))
    wrong, _, _ = load_map_server(yml)
    assert np.any((ros == -1) & (wrong == 0))
    png = g.save_png(tmp_path / "map.png")
    assert png.stat().st_size > 0


def test_bad_parameters_rejected():
    with pytest.raises(ValueError):
        OccupancyGrid(cells={"p_hit": 0.4, "p_miss": 0.7})
    with pytest.raises(ValueError):
        OccupancyGrid(cells={"free_threshold": 0.7, "occupied_threshold": 0.6})
    with pytest.raises(ValueError):
        OccupancyGrid(resolution=0)


def test_parameters_bad_values_unknown_keys_and_the_model_form():
    for bad, message in (
        ({"cells": {"p_hit": 1.0}}, "cells.p_hit"),
        ({"cells": {"p_miss": 0.5}}, "p_miss < p_prior < p_hit"),
        ({"cells": {"clamp": (0.6, 0.97)}}, "clamp"),
        ({"cells": {"clamp": (0.0, 0.97)}}, "cells.clamp.0"),
        ({"cells": {"hit_guard": -1}}, "cells.hit_guard"),
        ({"width": 0}, "width"),
        ({"dtype": "int8"}, "dtype"),
        ({"cells": {"free_threshold": 0.7}}, "free_threshold < occupied_threshold"),
        ({"no_such_parameter": 1}, "no_such_parameter"),
        ({"p_hit": 0.8}, "p_hit: not a parameter of OccupancyGridParams; did you mean cells.p_hit?"),
    ):
        with pytest.raises(ValidationError, match=re.escape(message)):
            OccupancyGrid(**bad)
    assert (
        OccupancyGrid(OccupancyGrid.Params(cells={"p_hit": 0.8}, width=10)).params
        == OccupancyGrid(cells={"p_hit": 0.8}, width=10).params
    )
    g = OccupancyGrid(cells={"p_hit": 0.8, "p_prior": 0.45}, width=10, height=4, resolution=0.2, dtype="float64")
    assert (
        g.l_hit == pytest.approx(logit(0.8)) and g.l0 == pytest.approx(logit(0.45)) and g.log_odds.dtype == np.float64
    )
    assert g.shape == (4, 10) and np.allclose(g.origin, [-1.0, -0.4])


def test_map_pyramid_parameters_reach_every_level():
    with pytest.raises(ValidationError, match="levels"):
        MapPyramid(levels=0)
    with pytest.raises(ValidationError, match="no_such_parameter"):
        MapPyramid(no_such_parameter=1)
    with pytest.raises(ValidationError, match="p_miss < p_prior < p_hit"):
        MapPyramid(cells={"p_hit": 0.45})
    assert MapPyramid(MapPyramid.Params(levels=2, size=4.0)).params == MapPyramid(levels=2, size=4.0).params
    cells = {"p_hit": 0.8, "clamp": None, "hit_guard": 1}
    maps = MapPyramid(resolution=0.1, levels=3, size=4.0, centre=(0.8, -1.6), cells=cells)
    assert [g.params.resolution for g in maps.levels] == pytest.approx([0.1, 0.2, 0.4])
    assert all(g.params.cells == maps.params.cells == CellModelParams(**cells) for g in maps.levels)
    assert all(
        np.allclose(g.grid_to_world(np.array(g.shape)[::-1] // 2), [0.8, -1.6]) for g in maps.levels
    )  # the middle cell on the centre


def test_hit_guard_keeps_cells_next_to_hits_from_being_cleared():
    # beam 0 ends at (1.0, 0.0); beam 1 passes just beside it to (1.5, 0.1), crossing cell (1.0, 0.1)
    ranges = [1.0, np.hypot(1.5, 0.1)]
    angles = [0.0, np.arctan2(0.1, 1.5)]
    plain, guarded = grid(), grid(hit_guard=1)
    for g in (plain, guarded):
        g.integrate(ranges, angles, [0.0, 0.0, 0.0], max_range=10.0)
    assert cell_p(plain, 1.0, 0.1) == pytest.approx(0.4, abs=1e-6)
    assert cell_p(guarded, 1.0, 0.1) == pytest.approx(0.5)
    assert cell_p(guarded, 0.5, 0.0) == pytest.approx(0.4, abs=1e-6)  # away from hits: cleared as before
    assert cell_p(guarded, 1.0, 0.0) == pytest.approx(0.7, abs=1e-6)


def test_vectorised_integration_equals_the_literal_loop():
    from slamarena.experiments.benchmarks.grid import integrate_literal

    rng = np.random.default_rng(7)
    angles = np.linspace(-2.0, 2.0, 150)
    fast, slow = (
        grid(clamp=(0.12, 0.97), grow=False),
        grid(clamp=(0.12, 0.97), grow=False),
    )  # rays leave the grid: both drop those cells
    for _ in range(6):
        pose = np.r_[rng.uniform(-0.5, 0.5, 2), rng.uniform(-np.pi, np.pi)]
        r = rng.uniform(0.05, 2.2, angles.size)
        r[rng.random(angles.size) < 0.1] = 2.0  # no-returns
        r[rng.random(angles.size) < 0.05] = np.nan
        n_fast = fast.integrate(r, angles, pose, mount=[0.1, 0.0, 0.2], max_range=2.0, clear_range=1.5)
        n_slow = integrate_literal(slow, r, angles, pose, mount=[0.1, 0.0, 0.2], max_range=2.0, clear_range=1.5)
        assert n_fast == n_slow
    assert np.array_equal(fast.log_odds, slow.log_odds)


def test_a_scan_traced_once_updates_pyramids_on_one_lattice_as_integrating_into_each():
    """MapPyramid.integrate(also=…): the cells traced in one pyramid moved into others (different centres, sizes and
    growth) give every level exactly the grid that integrating into each separately gives."""
    rng = np.random.default_rng(11)
    angles = np.linspace(-2.0, 2.0, 120)
    kw = dict(resolution=0.1, levels=3, cells={"clamp": (0.12, 0.97), "hit_guard": 1})
    shared = [
        MapPyramid(**kw, size=4.0, centre=(0.3, -0.7)),
        MapPyramid(**kw, size=2.0, centre=(-1.9, 2.4)),
        MapPyramid(**kw, size=9.0, centre=(5.0, 5.0)),
    ]
    alone = [MapPyramid(m.params) for m in shared]
    for _ in range(8):
        pose = np.r_[rng.uniform(-3, 3, 2), rng.uniform(-np.pi, np.pi)]
        r = rng.uniform(0.05, 4.0, angles.size)
        r[rng.random(angles.size) < 0.1] = 4.0  # no-returns
        n = shared[0].integrate(r, angles, pose, mount=[0.1, 0.0, 0.2], max_range=4.0, clear_range=2.5, also=shared[1:])
        assert [m.integrate(r, angles, pose, mount=[0.1, 0.0, 0.2], max_range=4.0, clear_range=2.5) for m in alone][
            0
        ] == n
        for grid in shared[0].levels:  # a released scratch is made again when the next scan comes
            grid.release_scratch()
    for a, b in zip(shared, alone):
        for ga, gb in zip(a.levels, b.levels):
            np.testing.assert_array_equal(ga.origin, gb.origin)
            np.testing.assert_array_equal(ga.log_odds, gb.log_odds)
    with pytest.raises(ValueError, match="one lattice"):
        shared[0].finest.cells_in(
            shared[0].finest.scan_cells([1.0], [0.0], [0, 0, 0], max_range=4.0),
            OccupancyGrid(resolution=0.1, origin=(0.01, 0.0)),
        )


@pytest.mark.parametrize(
    "ranges, angles, pose, match",
    [
        ([1.0, 2.0], [0.0, 0.1], [np.nan, 0.0, 0.0], "finite"),  # numpy's "Maximum allowed dimension exceeded"
        ([1.0, 2.0], [0.0, 0.1], [0.0, 0.0, np.inf], "finite"),
        ([1.0, 1e5], [0.0, 0.1], [0.0, 0.0, 0.0], "memory available"),  # a 29 TiB MemoryError at 5 cm cells
        ([1.0, 1e300], [0.0, 0.1], [0.0, 0.0, 0.0], "memory available"),
        ([1.0, 2.0, 3.0], [0.0, 0.1], [0.0, 0.0, 0.0], "one length"),  # an IndexError
        ([[1.0, 2.0]], [[0.0, 0.1]], [0.0, 0.0, 0.0], "1-D"),
    ],
)
def test_bad_scans_raise_a_clear_error_and_leave_the_grid_unchanged(ranges, angles, pose, match):
    g = OccupancyGrid(resolution=0.05)
    g.integrate([2.0, 3.0], [0.0, 1.0], [0.0, 0.0, 0.0])
    before = g.log_odds.copy(), g.origin.copy(), g.version, g.cell_updates
    with pytest.raises(ValueError, match=match):
        g.integrate(ranges, angles, pose)
    np.testing.assert_array_equal(g.log_odds, before[0])
    np.testing.assert_array_equal(g.origin, before[1])
    assert (g.version, g.cell_updates) == before[2:]


def test_the_mapping_methods_maps_start_on_a_square_twice_the_scans_reach_at_most_100_m():
    from slamarena.mapping.map_pyramid import PyramidParams

    pyramid = PyramidParams(resolution=0.1, levels=2, cells={"hit_guard": 1})
    for reach, side in ((4.0, 8.0), (80.0, 100.0)):
        maps = MapPyramid.around(pyramid, np.array([1.23, -4.5, 0.7]), reach)
        assert maps.params == MapPyramid.Params(
            resolution=0.1, levels=2, cells={"hit_guard": 1}, size=side, centre=(1.23, -4.5)
        )
        assert [g.params.cells for g in maps.levels] == [pyramid.cells] * 2
