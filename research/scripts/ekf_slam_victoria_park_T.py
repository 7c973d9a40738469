"""notebook/2026-11-23-ekf-slam-victoria-park.md, script T (T)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_T.py ekf_slam_nn ekf_slam_jcbb ekf_slam_nn_managed ekf_slam_jcbb_managed``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    end = {}
    for label in ["ekf_slam", "ekf_slam_identified", "gtsam_isam2", *sys.argv[1:]]:
        est = estimators.create(spec[label].name, **spec[label].resolved_params()).run(seq)
        end[label] = est.poses[-1, :2]
        print(
            label,
            est.meta.get("n_landmarks"),
            [est.meta.get(k) for k in ("removed_unconfirmed", "removed_quality", "matched", "new", "rejected")],
            [np.hypot(*(end[label] - end[r])) for r in ("ekf_slam", "ekf_slam_identified", "gtsam_isam2") if r in end],
        )


if __name__ == "__main__":
    main()
