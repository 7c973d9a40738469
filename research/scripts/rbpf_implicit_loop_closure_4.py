"""notebook/2026-11-23-rbpf-implicit-loop-closure.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_implicit_loop_closure_4.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.sim.laser import simulate
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    class Spread(RBPF):
        def _propose(self, *args):
            out = super()._propose(*args)
            self.spread.append(out[2].std())
            return out

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
        f = Spread(particles=30, seed=0)
        f.spread = []
        e = f.run(s)
        first = e.diagnostics["neff_t"] < s.scans.t[307]
        print(
            "world seed",
            seed,
            "median std of log η over the particles, first lap",
            round(float(np.median(np.array(f.spread)[first])), 2),
            "resamplings in the first lap",
            int(e.diagnostics["resampled"][first].sum()),
            "of",
            int(first.sum()),
            "filter steps",
            flush=True,
        )


if __name__ == "__main__":
    main()
