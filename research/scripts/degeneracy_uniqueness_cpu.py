"""CPU of the loop search's uniqueness test: the exhaustive response against the pruned one
(research/notebook/2026-11-28-degeneracy-2.md).

Usage: ``python research/scripts/degeneracy_uniqueness_cpu.py [WORLD]`` (a ``sim:laser`` world, default
``aliased_rooms``; 8 m laser). A map from every third scan of the first 300 at the true poses; the test at ± 5 m (the
cap) for 20 scans, each twice (numba compiled first). Prints both CPU times, their ratio and whether every superlevel set
was the same.
"""

from __future__ import annotations

import sys
import time
from types import SimpleNamespace

import numpy as np


def main(argv: list[str]) -> None:
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam.loop_closure import (
        _TILE_DEPTH,
        LoopCloser,
        LoopClosureParams,
        _best_over_angles,
        voxel_filter,
    )
    from slamarena.mapping.map_pyramid import MapPyramid, PyramidParams

    world = argv[0] if argv else "aliased_rooms"
    seq = simulate(world=world, seed=0, max_range=8.0)
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    maps = MapPyramid.around(PyramidParams(), truth[0], 30.0)
    for k in range(0, 300, 3):
        r, a = seq.scans.beams(k)
        maps.integrate(r, a, truth[k], seq.scans.mount, max_range=seq.scans.max_range)
    closer = LoopCloser(LoopClosureParams())
    cache = closer._precomputed(SimpleNamespace(index=0, maps=maps))
    m = closer.modes
    m.active = cache
    grid = maps.levels[closer.p.level]
    cases = []
    for k in range(10, 300, 15):
        r, a = seq.scans.beams(k)
        ok = np.isfinite(r) & (r < seq.scans.max_range)
        pts = voxel_filter(np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])]), closer.p.voxel)
        dth, na = m._angles(grid, pts)
        ix, iy = m._cells(
            grid, cache["pad"] - cache["corner"], pts, truth[k], truth[k, 2] + np.arange(-na, na + 1) * dth
        )
        cases.append((ix, iy, 2 * na + 1, closer.p.ambiguity * len(pts)))
    w = m._w(grid)
    same, cpu = True, {"exhaustive": 0.0, "pruned": 0.0}
    for repeat in range(2):
        for ix, iy, K, slack in cases:
            tic = time.process_time()
            S = m._response(cache["pyramid"][0], ix, iy, range(K), w, w)[0].max(axis=0)
            t1 = time.process_time()
            P = _best_over_angles(cache["pyramid"], _TILE_DEPTH, ix, iy, w, slack)
            t2 = time.process_time()
            if repeat:
                cpu["exhaustive"] += t1 - tic
                cpu["pruned"] += t2 - t1
            same &= bool(np.array_equal(S >= S.max() - slack, P >= P.max() - slack))
    print(
        f"{world}: {len(cases)} tests at ±{closer.p.linear_window} m: exhaustive {cpu['exhaustive']:.2f} s, pruned "
        f"{cpu['pruned']:.2f} s CPU, ratio {cpu['exhaustive'] / cpu['pruned']:.1f}; superlevel sets identical: {same}"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
