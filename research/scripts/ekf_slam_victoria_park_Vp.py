"""notebook/2026-11-23-ekf-slam-victoria-park.md, script V (V′ (and `- jcbb`))

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_Vp.py nn``.
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
    end = {
        k: estimators.create(spec[k].name, **spec[k].resolved_params()).run(seq).poses[-1, :2]
        for k in ("ekf_slam_identified", "gtsam_isam2")
    }
    base = spec[f"ekf_slam_{sys.argv[1]}_managed"].resolved_params()
    for change in [
        dict(window=0),
        dict(window=5),
        dict(window=10),
        dict(),
        dict(window=40),
        dict(window_hypotheses=1),
        dict(window_hypotheses=5),
        dict(confirm_sightings=2, confirm_window=10.0),
        dict(confirm_sightings=3, confirm_window=10.0),
        dict(jacobians="oc"),
    ]:
        est = estimators.create("ekf_slam", **{**base, **change}).run(seq)
        m = est.meta
        print(
            change,
            m["n_landmarks"],
            m["looked_ahead"],
            m["looked_ahead_matched"],
            m["removed_unconfirmed"],
            m["matched"],
            m["new"],
            m["rejected"],
            [round(float(np.hypot(*(est.poses[-1, :2] - end[k]))), 2) for k in end],
            flush=True,
        )


if __name__ == "__main__":
    main()
