"""notebook/2026-11-23-rbpf-proposal-vs-target.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_proposal_vs_target_3.py``.
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
    cal = dict(sigma_t_min=0.06, sigma_t_per_m=0.0, sigma_r_min=0.03, sigma_r_per_m=0.0)
    S = {"σ_z=1": {}, "σ_z=0.5": dict(sigma_likelihood=0.5), "σ_z=0.5, calib": dict(cal, sigma_likelihood=0.5)}
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
        steps = None
        row = [f"world seed {seed}"]
        for name, kw in S.items():
            e = RBPF(particles=1, **kw).run(s)
            if steps is None:
                steps = np.flatnonzero(e.diagnostics["filter_step"])
                row += ["GridSLAM", A(g), err(g, steps)]
            row += [name, A(e), err(e, steps)]
        print(*row, flush=True)


if __name__ == "__main__":
    main()
