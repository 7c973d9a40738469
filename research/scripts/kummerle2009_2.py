"""notebook/2026-11-23-kummerle2009.md, an inline command

Run from the repository root: ``python research/scripts/kummerle2009_2.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets
from slamarena.datasets.formats import relations as rf
from slamarena.datasets.geometry import between
from slamarena.mapping.frontend import FrontEnd
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.scan_matching.icp import Open3DICPMatcher


def main() -> None:
    s = datasets.load("carmen:mit-csail")
    g = GridSLAM()
    P = g.run(s).poses
    ipc = np.asarray(s.meta["scan_ipc_timestamp"])
    rel = rf.read(s.meta["relations"])
    i, j = (np.abs(ipc[None] - t[:, None]).argmin(1) for t in (rel.t1, rel.t2))
    f = FrontEnd(g.params, s.scans)
    m = Open3DICPMatcher(max_correspondence=0.15, max_iterations=100)
    pts = lambda k: (lambda p: p[np.linalg.norm(p, axis=1) < 20])(f.beams(k).points)
    n = np.flatnonzero(j - i <= 3)
    est = between(P[i[n]], P[j[n]])
    icp = np.array([m.match(pts(a), pts(b), e).pose for a, b, e in zip(i[n], j[n], est)])
    d = lambda x, y: np.linalg.norm(between(x, y)[:, :2], axis=1)
    [
        print(k, len(n), np.median(v), v.mean())
        for k, v in (("icp-ours", d(est, icp)), ("icp-ref", d(rel.se2[n], icp)), ("ours-ref", d(rel.se2[n], est)))
    ]


if __name__ == "__main__":
    main()
