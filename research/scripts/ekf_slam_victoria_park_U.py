"""notebook/2026-11-23-ekf-slam-victoria-park.md, script U (U)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_U.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    print("ids seen once:", sum(np.bincount(np.unique(seq.range_bearing.landmark_id, return_inverse=True)[1]) == 1))
    twice = {(34, 189), (41, 179), (108, 756)}  # one tree under two ids ((b) above)
    for label in ("ekf_slam_nn_managed", "ekf_slam_jcbb_managed"):
        est = estimators.create("ekf_slam", **spec[label].resolved_params()).run(seq)
        d = est.diagnostics
        dec, lm, given = d["assoc_decision"], d["assoc_landmark"], d["assoc_given_id"]
        creator = dict(zip(lm[dec == 1], given[dec == 1]))  # the id in the data of the row that created each landmark
        same = [
            creator[a] == g or tuple(sorted((creator[a], g))) in twice for a, g in zip(lm[dec == 0], given[dec == 0])
        ]
        print(
            label,
            est.meta["n_landmarks"],
            "distinct ids among them:",
            len(set(creator.values())),
            "matches consistent with the ids: %.3f" % np.mean(same),
            "looked ahead at",
            d["looked_ahead_t"].tolist(),
        )


if __name__ == "__main__":
    main()
