"""Laser graph SLAM's CPU with the pruned uniqueness test against the exhaustive one, on a staged log
(research/notebook/2026-11-28-degeneracy-2.md).

Usage: ``python research/scripts/degeneracy_uniqueness_log.py LOG`` (a registry name, e.g. carmen:intel), shipped
defaults. Runs the log twice, the second time with ``LoopCloser._regions`` counting on the exhaustive response (the
code before); prints each run's CPU per part and whether poses and loop verdicts are identical.
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.ndimage import label


def _exhaustive_regions(self, submap, points, pose, linear):
    m = self.modes
    m.params = m.params.model_copy(update={"linear_window": linear})
    grid = submap.maps.levels[min(self.p.level, len(submap.maps.levels) - 1)]
    dth, na = m._angles(grid, points)
    cache = m._grids(submap.maps, 0, pose, 0.0)
    offsets = np.arange(-na, na + 1) * dth
    ix, iy = m._cells(grid, cache["pad"] - cache["corner"], points, pose, pose[2] + offsets)
    S, _, _ = m._response(cache["pyramid"][0], ix, iy, range(offsets.size), m._w(grid), m._w(grid))
    best = S.max(axis=0)
    return int(label(best >= best.max() - self.p.ambiguity * len(points), structure=np.ones((3, 3)))[1])


def main(argv: list[str]) -> None:
    from slamarena.datasets.registry import load
    from slamarena.mapping.laser_slam import loop_closure
    from slamarena.mapping.laser_slam.slam import LaserSLAM

    seq = load(argv[0])
    runs = {}
    for name in ("pruned", "exhaustive"):
        if name == "exhaustive":
            loop_closure.LoopCloser._regions = _exhaustive_regions
        est = LaserSLAM().run(seq)
        runs[name] = est
        s = est.meta["seconds"]
        print(
            f"{argv[0]} {name}: CPU {sum(s.values()):.1f} s ({', '.join(f'{k} {v:.1f}' for k, v in s.items())}); "
            f"loops {est.meta['loop_closures']} of {est.meta['loop_candidates']}, {est.meta['loop_rejected_by']}"
        )
    a, b = runs["pruned"], runs["exhaustive"]
    print(
        f"identical poses: {np.array_equal(a.poses, b.poses)}; identical verdicts: "
        f"{np.array_equal(a.diagnostics['loop_test'], b.diagnostics['loop_test'])}"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
