"""notebook/2026-11-23-fastslam-consistency.md, script 1

Run from the repository root: ``python research/scripts/fastslam_consistency_1.py 100 40 0``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py);
``--quick`` runs it at the smallest size (``QUICK``), which the slow tests do.
"""

import json
import sys
from types import SimpleNamespace

import numpy as np

from slamarena.datasets.geometry import between
from slamarena.datasets.sim.landmarks import simulate
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def main() -> None:
    M, worlds, offset = (
        int(sys.argv[1]),
        range(int(sys.argv[2])),
        int(sys.argv[3]),
    )  # particles, worlds 0…N−1, filter seed − world seed
    sim = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}  # simulator overrides, e.g. '{"sigma_v": 0.4}'
    rows = []
    for s in worlds:
        seq = simulate(laps=2, seed=s, **sim)
        row = {}
        for v in (1, 2):
            est = FastSLAM(version=v, particles=M, seed=s + offset).run(seq)
            a, series = ate(est, reference_of(seq), ATEParams(align="se2", max_gap=0.05))
            path = ate(
                SimpleNamespace(t=est.t, poses=est.diagnostics["best_poses"]),
                reference_of(seq),
                ATEParams(align="se2", max_gap=0.05),
            )[0]
            g, p = series["gt_poses"], series["aligned_poses"]
            step = between(between(g[:-1], g[1:]), between(p[:-1], p[1:]))  # error of each 0.1 s step, robot frame
            row[v] = (a["rmse"], path["rmse"], np.sqrt(np.mean(step[:, 1] ** 2)), est.meta["resamplings"])
        rows.append(row)
        print(s, json.dumps(row), flush=True)
    for i, name in enumerate(
        [
            "ATE RMSE, weighted mean [m]",
            "ATE RMSE, ancestral path of the heaviest particle [m]",
            "lateral error of a 0.1 s step [m]",
            "resamplings",
        ]
    ):
        one, two = (np.array([r[v][i] for r in rows]) for v in (1, 2))
        d, n = two - one, len(rows)
        print(
            f"{name}: 1.0 {one.mean():.4f} ± {one.std(ddof=1) / n**0.5:.4f}, 2.0 {two.mean():.4f} ± {two.std(ddof=1) / n**0.5:.4f}, "
            f"2.0 − 1.0 {d.mean():+.4f} ± {d.std(ddof=1) / n**0.5:.4f} (2.0 higher in {(d > 0).sum()} of {n})"
        )


#: ``--quick``: the smallest run through every line, 5 particles, world 0 only (the page runs 100 particles on 40 worlds).
QUICK = ["5", "1", "0"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
