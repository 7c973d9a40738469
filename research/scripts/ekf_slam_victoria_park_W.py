"""notebook/2026-11-23-ekf-slam-victoria-park.md, script W (W)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_W.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    rb = seq.range_bearing
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    isam2 = estimators.create("gtsam_isam2", **spec["gtsam_isam2"].resolved_params()).run(seq)
    L = dict(zip(isam2.landmark_ids.tolist(), isam2.landmarks))
    ids = np.array(list(L))
    xy = np.array(list(L.values()))
    for k in np.flatnonzero((rb.t >= 4866) & (rb.t <= 4868)):
        p = isam2.poses[int(rb.t[k])]
        w = p[:2] + rb.range[k] * np.array([np.cos(p[2] + rb.bearing[k]), np.sin(p[2] + rb.bearing[k])])
        d = np.hypot(*(xy - w).T)
        o = np.argsort(d)[:3]
        print(rb.t[k], rb.landmark_id[k], [(int(ids[i]), round(float(d[i]), 2)) for i in o])


if __name__ == "__main__":
    main()
