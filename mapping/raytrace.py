"""Integer Bresenham ray tracing, vectorised over all beams of a scan.

For a line from cell ``(x0, y0)`` to ``(x1, y1)`` let ``D = max(|Δx|, |Δy|)`` (the major
axis length) and ``m = min(|Δx|, |Δy|)``. The classic integer Bresenham loop (error term
``e = 2m − D``, step the minor axis when ``e > 0``) visits ``D + 1`` cells; at major step
``i`` its minor offset has the closed form

    k_i = ⌊(2·i·m + D − 1) / (2·D)⌋          (i = 0 … D;  D = 0 → the single cell)

i.e. ``round(i·m/D)`` with exact halves rounded towards the start. Because ``k_i`` needs only
integer arithmetic, all cells of all beams are produced at once: ``np.repeat`` lays out the
``D + 1`` steps of every beam and the closed form fills them in. The loop form lives in the
tests as the reference the closed form is checked against (all octants, degenerate lines).
"""

from __future__ import annotations

import numpy as np

__all__ = ["bresenham"]


def bresenham(x0, y0, x1, y1) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cells of the lines ``(x0, y0) → (x1, y1)`` (integer arrays, broadcast together).

    Returns ``(x, y, line, step)``: the cells of every line in order from start to end,
    the index of the line each cell belongs to, and the step ``i`` along it (the end cell
    of line ``j`` has ``step == D_j``). Total length ``Σ_j (D_j + 1)``.
    """
    x0, y0, x1, y1 = (np.asarray(v, dtype=np.int64).ravel() for v in np.broadcast_arrays(x0, y0, x1, y1))
    dx, dy = x1 - x0, y1 - y0
    ax, ay = np.abs(dx), np.abs(dy)
    D = np.maximum(ax, ay)
    m = np.minimum(ax, ay)
    n = D + 1
    line = np.repeat(np.arange(D.size), n)
    first = np.cumsum(n) - n
    step = np.arange(line.size, dtype=np.int64) - first[line]
    Dl = D[line]
    minor = (2 * step * m[line] + Dl - 1) // np.maximum(2 * Dl, 1)
    x_major = (ax >= ay)[line]
    x = x0[line] + np.sign(dx)[line] * np.where(x_major, step, minor)
    y = y0[line] + np.sign(dy)[line] * np.where(x_major, minor, step)
    return x, y, line, step
