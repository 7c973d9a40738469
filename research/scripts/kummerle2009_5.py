"""notebook/2026-11-23-kummerle2009.md, an inline command

Run from the repository root: ``python research/scripts/kummerle2009_5.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np


def main() -> None:
    for l in ["intel", "fr079", "mit_csail", "fr_clinic"]:
        z = np.load(f"results/kummerle2009/runs/{l}/rbpf/0/estimate.npz", allow_pickle=True)
        mem = z["diag/memory_per_particle"]
        mem = mem[np.isfinite(mem) & (mem > 0)]
        print(
            l,
            "median neff/P %.2f" % np.median(z["diag/neff"] / 50),
            "resampled",
            int(z["diag/resampled"].sum()),
            "filter steps",
            int(z["diag/filter_step"].sum()),
            "MB per particle at the end %.2f" % (mem[-1] / 2**20),
        )


if __name__ == "__main__":
    main()
