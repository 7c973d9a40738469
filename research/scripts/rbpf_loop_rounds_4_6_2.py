"""notebook/2026-11-23-rbpf-loop-rounds-4-6.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_4_6_2.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.geometry import between, wrap_angle
from slamarena.datasets.sim.laser import simulate
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    for seed in (0, 1, 2):
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
        gt = s.ground_truth.poses[np.searchsorted(s.ground_truth.t, s.scans.t)]
        ests = {
            "GridSLAM": GridSLAM().run(s),
            **{f"one particle, halvings {h}": RBPF(particles=1, seed=0, step_halvings=h).run(s) for h in (0, 4)},
        }
        steps = np.flatnonzero(ests["one particle, halvings 0"].diagnostics["filter_step"])
        for name, e in ests.items():
            d = between(e.poses[steps[:-1]], e.poses[steps[1:]]) - between(gt[steps[:-1]], gt[steps[1:]])
            d[:, 2] = wrap_angle(d[:, 2])
            print(
                seed,
                name,
                np.round(1e3 * np.sqrt(np.mean(d**2, axis=0)), 1).tolist(),
                "GN iterations",
                e.diagnostics["iterations"].sum(),
            )


if __name__ == "__main__":
    main()
