"""notebook/2026-11-23-rbpf-loop-rounds-1-3.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_1_3_1.py 44 28``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import math
import sys

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sim.laser import corridor_loop, simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.grid_slam import GridSLAM


def main() -> None:
    W, H = map(float, sys.argv[1:3])
    world = corridor_loop(W, H)
    for seed in range(10):
        s = simulate(
            world=world,
            max_range=4.0,
            n_beams=91,
            sigma_range=0.02,
            k_r=0.06,
            k_rt=0.03,
            k_t=0.085,
            scan_rate=2.5,
            laps=2,
            seed=seed,
        )
        gt = s.ground_truth.poses[np.searchsorted(s.ground_truth.t, s.scans.t)]
        lap = math.ceil(s.meta["steps_per_lap"] / round(s.meta["odom_rate"] / s.meta["scan_rate"]))
        out = []
        for e in (GridSLAM().run(s), Estimate("odometry", s.scans.t, s.scans.pose)):
            err = np.hypot(*(e.poses[:, :2] - gt[:, :2]).T)
            out += [ate(e, reference_of(s), ATEParams())[0]["rmse"], err[lap], err[: lap + 1].max()]
        print(
            "world seed",
            seed,
            "GridSLAM: ATE %.3f, end of lap 1 %.3f, max in lap 1 %.3f | dead reckoning: ATE %.3f, end of lap 1 %.3f, max in lap 1 %.3f"
            % tuple(out),
            flush=True,
        )


if __name__ == "__main__":
    main()
