"""notebook/2026-11-23-kummerle2009.md, an inline command

Run from the repository root: ``python research/scripts/kummerle2009_4.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.geometry import between
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM


def main() -> None:
    s = simulate(laps=2, k_r=0.1, k_rt=0.03, n_beams=181, seed=3)
    g = s.ground_truth
    T = g.poses[np.searchsorted(g.t, s.scans.t)]
    for m in (0, 1, 2):
        e = LaserSLAM(max_usable_range=6.0, search_every=2, tracking="submap", refine_neighbours=m).run(s)
        P = e.poses
        print(
            m,
            ate(e, reference_of(s), ATEParams(align="se2"))[0]["rmse"],
            [
                np.linalg.norm(between(P[:-d], P[d:])[:, :2] - between(T[:-d], T[d:])[:, :2], axis=1).mean()
                for d in (1, 3)
            ],
        )


if __name__ == "__main__":
    main()
