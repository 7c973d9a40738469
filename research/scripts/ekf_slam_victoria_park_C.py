"""notebook/2026-11-23-ekf-slam-victoria-park.md, script C (C: the rows without ids, against the EKF with ids)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_C.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    run = lambda label, **kw: estimators.create("ekf_slam", **{**spec[label].resolved_params(), **kw}).run(seq)
    ref, est = run("ekf_slam"), run("ekf_slam_nn")
    d = est.diagnostics
    err = np.hypot(*(est.poses[:, :2] - ref.poses[np.searchsorted(ref.t, est.t), :2]).T)
    print([est.t[np.argmax(err > x)] for x in (1, 5, 20)], err[-1])
    seen = set()
    for a, g, t, d2 in zip(d["assoc_decision"], d["assoc_given_id"], d["assoc_t"], d["assoc_d2"]):
        if 150 <= t <= 520 and (a == 2 or (a == 1 and g in seen)):
            print(t, g, "rejected" if a == 2 else "new, seen before", d2)
        seen.add(int(g))


if __name__ == "__main__":
    main()
