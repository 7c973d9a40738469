"""notebook/2026-11-23-fastslam-victoria-park-no-ids.md, script 1

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_1.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    cfg = load_config("mrclam")
    d = cfg.datasets[0]
    est = FastSLAM(**{(e.label or e.name): e for e in cfg.estimators}["fastslam"].resolved_params()).run(
        datasets.load(d.name, **d.params)
    )
    ref = Estimate.load("results/mrclam/runs/robot1/fastslam/0/estimate.npz")
    print(np.abs(est.poses - ref.poses).max(), len(est.landmark_ids), np.abs(est.landmarks - ref.landmarks).max())


if __name__ == "__main__":
    main()
