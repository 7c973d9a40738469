"""Error along the first corridor of the ``sim:laser`` world ``corridor`` (research/notebook/2026-11-28-degeneracy.md).

Usage: ``python research/scripts/degeneracy_1.py METHOD TAU [SEED] [PARTICLES]`` with METHOD grid_slam,
laser_slam or rbpf and TAU the ``degeneracy_threshold``. Prints the largest |error along x| on the featureless stretch
(x 41–64 m, first pass; relative to its start) of the odometry and of the method, the same up to x = 76 m (the end
wall in view), and the final position error.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def along(truth: np.ndarray, poses: np.ndarray, x_max: float) -> float:
    first = np.arange(len(truth)) < np.argmax(truth[:, 1] > 3.0)
    on = first & (truth[:, 0] > 41.0) & (truth[:, 0] < x_max)
    e = poses[on, 0] - truth[on, 0]
    return float(np.abs(e - e[0]).max())


def main(argv: list[str]) -> None:
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.grid_slam import GridSLAM
    from slamarena.mapping.laser_slam.slam import LaserSLAM
    from slamarena.mapping.rbpf import RBPF

    method, tau = argv[0], float(argv[1])
    seed = int(argv[2]) if len(argv) > 2 else 0
    seq = simulate(world="corridor", seed=seed)
    front = {"matcher_params": {"degeneracy_threshold": tau}}
    make = {
        "grid_slam": lambda: GridSLAM(frontend=front),
        "laser_slam": lambda: LaserSLAM(frontend=front),
        "rbpf": lambda: RBPF(particles=int(argv[3]) if len(argv) > 3 else 30, degeneracy_threshold=tau),
    }[method]
    cpu = time.process_time()
    est = make().run(seq)
    cpu = time.process_time() - cpu
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    odo = seq.scans.pose
    print(
        f"{method} tau={tau:g} seed={seed}: along x 41-64 m odometry {along(truth, odo, 64.0):.3f} method "
        f"{along(truth, est.poses, 64.0):.3f}; x 41-76 m odometry {along(truth, odo, 76.0):.3f} method "
        f"{along(truth, est.poses, 76.0):.3f}; final error {np.hypot(*(est.poses[-1, :2] - truth[-1, :2])):.3f} m; "
        f"cpu {cpu:.0f} s"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
