"""notebook/2026-11-23-ekf-slam-victoria-park.md, script V (V)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_V.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

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
    base = spec["ekf_slam_nn_managed"].resolved_params()
    for change in [
        dict(confirm_sightings=1),
        dict(confirm_sightings=2),
        dict(),
        dict(confirm_sightings=4),
        dict(confirm_window=5.0),
        dict(confirm_window=20.0),
        dict(jacobians="oc"),
        dict(association="jcbb", confirm_sightings=2),
        dict(miss_limit=5, sensor_range=20.0, sensor_fov=3.14159),
    ]:
        est = estimators.create("ekf_slam", **{**base, **change}).run(seq)
        m = est.meta
        print(
            change,
            m["n_landmarks"],
            m["removed_unconfirmed"],
            m["removed_quality"],
            m["matched"],
            m["new"],
            m["rejected"],
            [np.hypot(*(est.poses[-1, :2] - end[k])) for k in end],
        )


if __name__ == "__main__":
    main()
