"""notebook/2026-11-23-rbpf-loop-rounds-4-6.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_4_6_1.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.formats import relations as R
from slamarena.datasets.geometry import between
from slamarena.datasets.log_stamps import sequence_times as _to_sequence_time
from slamarena.datasets.registry import load


def main() -> None:
    for name in ("intel", "fr079", "mit-csail", "fr-clinic"):
        s = load(f"carmen:{name}")
        rel = R.read(s.meta["relations"])
        t1, t2 = _to_sequence_time(s, rel.t1, 1e-3), _to_sequence_time(s, rel.t2, 1e-3)
        ok = np.isfinite(t1) & np.isfinite(t2)
        du = between(s.scans.pose[np.searchsorted(s.scans.t, t1[ok])], s.scans.pose[np.searchsorted(s.scans.t, t2[ok])])
        ref = rel.se2[ok]
        e = between(ref, du)
        dref = np.hypot(*ref[:, :2].T)
        lo, hi = (0.7, 1.5) if name == "fr-clinic" else (0.3, 0.7)
        m = (dref >= lo) & (dref < hi) & (np.abs(ref[:, 2]) < 0.3) & (np.abs(t2[ok] - t1[ok]) < 10)
        print(
            name,
            m.sum(),
            "median travel %.2f" % np.median(dref[m]),
            "rms / p95 along, lateral, heading",
            [("%.3f / %.3f" % (np.sqrt(np.mean(e[m, c] ** 2)), np.percentile(np.abs(e[m, c]), 95))) for c in range(3)],
        )


if __name__ == "__main__":
    main()
