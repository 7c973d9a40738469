"""notebook/2026-11-23-rbpf-loop-rounds-1-3.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_1_3_4.py 100 0 1 2 3 4 5 6 7 8 9``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py);
``--quick`` runs it at the smallest size (``QUICK``), which the slow tests do.
"""

import sys
import time

import numpy as np

from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    for seed in map(int, sys.argv[2:]):
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
        truth = s.ground_truth.poses[np.searchsorted(s.ground_truth.t, s.scans.t)]
        before = (len(truth) - 1) // 2 - 25
        f = RBPF(particles=int(sys.argv[1]), seed=0)
        t0 = time.process_time()
        e = f.run(s)
        cpu = time.process_time() - t0
        near = np.hypot(*(f._history[0][before, :, :2] - truth[before, :2]).T).min()
        print(
            "world seed",
            seed,
            "particles",
            sys.argv[1],
            "best ATE %.3f (resamplings %d, CPU %.0f s), nearest particle 5 m before the loop %.2f m"
            % (ate(e, reference_of(s), ATEParams())[0]["rmse"], e.meta["resampling_events"], cpu, near),
            flush=True,
        )


#: ``--quick``: the smallest run through every line, 2 particles on world seed 0 (the page runs 100 particles on ten seeds).
QUICK = ["2", "0"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
