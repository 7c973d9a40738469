"""notebook/2026-11-23-rbpf-implicit-loop-closure.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_implicit_loop_closure_2.py default,g1/2,g1/3,thr0.25,g1/90,calib,calib-g1/90,sz0.5,sz2,sz0.5-g1/4,sz0.5-g1/12 0 1 2 3 4 5 6 7 8 9``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py);
``--quick`` runs it at the smallest size (``QUICK``), which the slow tests do.
"""

import sys

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    cal = dict(sigma_t_min=0.06, sigma_t_per_m=0.0, sigma_r_min=0.03, sigma_r_per_m=0.0)
    S = {
        "default": {},
        "g1/2": dict(weight_tempering=1 / 2),
        "g1/3": dict(weight_tempering=1 / 3),
        "thr0.25": dict(resample_threshold=0.25),
        "g1/90": dict(weight_tempering=1 / 90),
        "calib": cal,
        "calib-g1/90": dict(cal, weight_tempering=1 / 90),
        "sz0.5": dict(sigma_likelihood=0.5),
        "sz2": dict(sigma_likelihood=2.0),
        "sz0.5-g1/4": dict(sigma_likelihood=0.5, weight_tempering=1 / 4),
        "sz0.5-g1/12": dict(sigma_likelihood=0.5, weight_tempering=1 / 12),
    }
    for seed in map(int, sys.argv[2:]):
        s = simulate(
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
        print("world seed", seed, "GridSLAM", round(A(GridSLAM().run(s).poses), 3), flush=True)
        for name in sys.argv[1].split(","):
            f = RBPF(particles=30, seed=0, **S[name])
            e = f.run(s)
            up = np.arange(30)
            for k in range(307, 153, -1):
                up = f._history[1][k, up]
            print(
                " ",
                name,
                "best",
                round(A(e.poses), 3),
                "resamplings",
                e.meta["resampling_events"],
                "best of the 30 final lineages",
                round(min(A(f.trajectory(i)) for i in range(30)), 3),
                "lineages at the loop (scan 307) distinct since scan 153",
                np.unique(up).size,
                flush=True,
            )


#: ``--quick``: the smallest run through every line, the default setting on world seed 0 (the page runs eleven settings on ten seeds).
QUICK = ["default", "0"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
