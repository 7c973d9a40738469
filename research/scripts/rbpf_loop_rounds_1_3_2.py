"""notebook/2026-11-23-rbpf-loop-rounds-1-3.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_1_3_2.py 0 1 2 3 4 5 6 7 8 9``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
import time

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    for seed in map(int, sys.argv[1:]):
        s = simulate(
            world="long_loop",
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
        A = lambda p: ate(Estimate("x", s.scans.t, p), reference_of(s), ATEParams())[0]["rmse"]
        g = GridSLAM().run(s)
        f = RBPF(particles=30, seed=0)
        t0 = time.process_time()
        e = f.run(s)
        cpu = time.process_time() - t0
        lineages = np.array([f.trajectory(i) for i in range(30)])
        one = RBPF(particles=1, seed=0).run(s)
        print(
            "world seed",
            seed,
            "GridSLAM %.3f | best of 30 %.3f (resamplings %d, CPU %.0f s) | one particle %.3f | best of the 30 final lineages %.3f"
            % (A(g.poses), A(e.poses), e.meta["resampling_events"], cpu, A(one.poses), min(A(p) for p in lineages)),
            flush=True,
        )
        np.savez(
            f"/tmp/long_loop_seed{seed}.npz",
            truth=s.ground_truth.poses[np.searchsorted(s.ground_truth.t, s.scans.t)],
            grid=g.poses,
            best=e.poses,
            population=f._history[0],
            parents=f._history[1],
            resampled=e.diagnostics["resampled"],
            neff_t=e.diagnostics["neff_t"],
            t=s.scans.t,
        )


if __name__ == "__main__":
    main()
