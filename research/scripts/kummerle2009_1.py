"""notebook/2026-11-23-kummerle2009.md, an inline command

Run from the repository root: ``python research/scripts/kummerle2009_1.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets
from slamarena.datasets.formats import relations as rf
from slamarena.datasets.geometry import between


def main() -> None:
    s = datasets.load("carmen:mit-csail")
    ipc = np.asarray(s.meta["scan_ipc_timestamp"])
    rel = rf.read(s.meta["relations"])
    O = s.scans.pose
    i, j = (np.abs(ipc[None] - t[:, None]).argmin(1) for t in (rel.t1, rel.t2))
    fresh = np.array([b - a <= 3 and all(np.any(O[k] != O[k - 1]) for k in range(a + 1, b + 1)) for a, b in zip(i, j)])
    d = np.linalg.norm(rel.se2[fresh, :2] - between(O[i], O[j])[fresh, :2], axis=1) / 0.05
    print(
        fresh.sum(),
        {v: int(np.sum(np.abs(d - v) < 0.02)) for v in (0, 1, 2**0.5, 2, 5**0.5)},
        "off the lattice:",
        int(np.sum(np.abs(d - np.round(d * d) ** 0.5) >= 0.02)),
    )


if __name__ == "__main__":
    main()
