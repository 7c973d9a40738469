"""Bresenham closed form vs the textbook integer loop and hand-checked reference lines."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.mapping.raytrace import bresenham


def bresenham_loop(x0, y0, x1, y1):
    """The classic integer Bresenham loop (error term 2m − D, minor step when e > 0)."""
    dx, dy = abs(x1 - x0), abs(y1 - y0)
    sx, sy = (1 if x1 >= x0 else -1), (1 if y1 >= y0 else -1)
    cells = []
    if dx >= dy:
        e, y = 2 * dy - dx, y0
        for i in range(dx + 1):
            cells.append((x0 + i * sx, y))
            if e > 0:
                y, e = y + sy, e - 2 * dx
            e += 2 * dy
    else:
        e, x = 2 * dx - dy, x0
        for i in range(dy + 1):
            cells.append((x, y0 + i * sy))
            if e > 0:
                x, e = x + sx, e - 2 * dy
            e += 2 * dx
    return cells


REFERENCE = {
    # hand-checked lines: first octant slope 2/5, and its images in the other octants
    ((0, 0), (5, 2)): [(0, 0), (1, 0), (2, 1), (3, 1), (4, 2), (5, 2)],
    ((0, 0), (2, 5)): [(0, 0), (0, 1), (1, 2), (1, 3), (2, 4), (2, 5)],
    ((0, 0), (-5, 2)): [(0, 0), (-1, 0), (-2, 1), (-3, 1), (-4, 2), (-5, 2)],
    ((0, 0), (-2, 5)): [(0, 0), (0, 1), (-1, 2), (-1, 3), (-2, 4), (-2, 5)],
    ((0, 0), (-5, -2)): [(0, 0), (-1, 0), (-2, -1), (-3, -1), (-4, -2), (-5, -2)],
    ((0, 0), (-2, -5)): [(0, 0), (0, -1), (-1, -2), (-1, -3), (-2, -4), (-2, -5)],
    ((0, 0), (5, -2)): [(0, 0), (1, 0), (2, -1), (3, -1), (4, -2), (5, -2)],
    ((0, 0), (2, -5)): [(0, 0), (0, -1), (1, -2), (1, -3), (2, -4), (2, -5)],
    # degenerate: zero length, horizontal, vertical, diagonals
    ((3, 4), (3, 4)): [(3, 4)],
    ((1, 1), (4, 1)): [(1, 1), (2, 1), (3, 1), (4, 1)],
    ((1, 1), (-2, 1)): [(1, 1), (0, 1), (-1, 1), (-2, 1)],
    ((7, -1), (7, 2)): [(7, -1), (7, 0), (7, 1), (7, 2)],
    ((7, 2), (7, -1)): [(7, 2), (7, 1), (7, 0), (7, -1)],
    ((0, 0), (3, 3)): [(0, 0), (1, 1), (2, 2), (3, 3)],
    ((0, 0), (-3, 3)): [(0, 0), (-1, 1), (-2, 2), (-3, 3)],
    ((0, 0), (-3, -3)): [(0, 0), (-1, -1), (-2, -2), (-3, -3)],
    ((0, 0), (3, -3)): [(0, 0), (1, -1), (2, -2), (3, -3)],
    # exact half: (0,0)→(2,1) passes y = 0.5 at x = 1; ties go towards the start
    ((0, 0), (2, 1)): [(0, 0), (1, 0), (2, 1)],
}


def _cells(x, y, line, j):
    sel = line == j
    return list(zip(x[sel].tolist(), y[sel].tolist()))


def test_reference_lines_all_at_once():
    keys = list(REFERENCE)
    a = np.array([k[0] for k in keys])
    b = np.array([k[1] for k in keys])
    x, y, line, step = bresenham(a[:, 0], a[:, 1], b[:, 0], b[:, 1])
    for j, key in enumerate(keys):
        assert _cells(x, y, line, j) == REFERENCE[key], key
        assert _cells(x, y, line, j) == bresenham_loop(*key[0], *key[1])
    assert np.all(step[np.r_[np.flatnonzero(np.diff(line)), line.size - 1]] == [len(REFERENCE[k]) - 1 for k in keys])


def test_matches_loop_on_every_endpoint_of_a_window():
    ends = np.array([(i, j) for i in range(-17, 18) for j in range(-17, 18)])
    x0, y0 = 5, -8
    x, y, line, _ = bresenham(x0, y0, x0 + ends[:, 0], y0 + ends[:, 1])
    for j, (i, k) in enumerate(ends):
        assert _cells(x, y, line, j) == bresenham_loop(x0, y0, x0 + i, y0 + k)


@pytest.mark.parametrize("seed", range(3))
def test_cells_are_8_connected_and_end_on_target(seed):
    rng = np.random.default_rng(seed)
    p = rng.integers(-500, 500, size=(200, 4))
    x, y, line, step = bresenham(p[:, 0], p[:, 1], p[:, 2], p[:, 3])
    same = line[1:] == line[:-1]
    assert np.all(np.maximum(np.abs(np.diff(x)), np.abs(np.diff(y)))[same] == 1)
    last = np.r_[np.flatnonzero(~same), line.size - 1]
    assert np.array_equal(x[last], p[:, 2]) and np.array_equal(y[last], p[:, 3])
    assert np.array_equal(np.bincount(line), np.maximum(np.abs(p[:, 2] - p[:, 0]), np.abs(p[:, 3] - p[:, 1])) + 1)
