"""notebook/2026-11-23-rbpf-mode-proposal-measured.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_measured_1.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.geometry import between, wrap_angle
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    for seed in range(10):
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
        A = lambda e: round(ate(e, reference_of(s), ATEParams())[0]["rmse"], 3)
        gt = s.ground_truth.poses[np.searchsorted(s.ground_truth.t, s.scans.t)]

        def err(e, steps):
            d = between(e.poses[steps[:-1]], e.poses[steps[1:]]) - between(gt[steps[:-1]], gt[steps[1:]])
            d[:, 2] = wrap_angle(d[:, 2])
            return np.round(1e3 * np.sqrt(np.mean(d**2, axis=0)), 1).tolist()

        g = GridSLAM().run(s)
        one = RBPF(particles=1, proposal="mode").run(s)
        steps = np.flatnonzero(one.diagnostics["filter_step"])
        f = RBPF(particles=30, proposal="mode")
        e = f.run(s)
        print(
            "world seed",
            seed,
            "GridSLAM",
            A(g),
            err(g, steps),
            "mode: one particle",
            A(one),
            err(one, steps),
            "30 particles: best",
            A(e),
            "resamplings",
            e.meta["resampling_events"],
            "best of the 30 final lineages",
            round(min(A(type(e)("x", s.scans.t, f.trajectory(i))) for i in range(30)), 3),
            flush=True,
        )


if __name__ == "__main__":
    main()
