"""notebook/2026-11-23-ekf-slam-victoria-park.md, script J (J)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_J.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    ref = estimators.create("ekf_slam", **spec["ekf_slam_identified"].resolved_params()).run(seq)
    est = estimators.create("ekf_slam", **{**spec["ekf_slam_jcbb_managed"].resolved_params(), "window": 10}).run(seq)
    d = est.diagnostics
    off = np.hypot(
        *(est.poses[:, :2] - ref.poses[np.searchsorted(ref.t, est.t), :2]).T
    )  # from the EKF with ids (identified)
    creator = {}
    print(
        "looked ahead at",
        d["looked_ahead_t"].tolist(),
        "first step > 10 / 20 m off:",
        [est.t[np.argmax(off > x)] for x in (10, 20)],
        "largest %.1f m at %d" % (off.max(), est.t[off.argmax()]),
        "final %.2f m" % off[-1],
    )
    for a, lm, g, t, d2 in zip(
        d["assoc_decision"], d["assoc_landmark"], d["assoc_given_id"], d["assoc_t"], d["assoc_d2"]
    ):
        creator.setdefault(lm, g) if a == 1 else None
        if 5585 <= t <= 5632:
            print(
                int(t),
                "MNR"[a],
                "row labelled",
                g,
                "landmark created from",
                creator.get(lm),
                "d² %.1f" % d2,
                "%.1f m off" % off[np.searchsorted(est.t, t)],
            )


if __name__ == "__main__":
    main()
