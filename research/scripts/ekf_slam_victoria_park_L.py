"""notebook/2026-11-23-ekf-slam-victoria-park.md, script L (L)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_L.py nn 4866``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import copy
import dataclasses
import sys

import numpy as np

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    rb, mo = seq.range_bearing, seq.motion
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    params = spec[f"ekf_slam_{sys.argv[1]}_managed"].resolved_params()
    t_row = float(sys.argv[2])
    ekf = EKFSLAM(**{**params, "window": 0})  # the filter up to the set at t_row
    ekf.run(dataclasses.replace(seq, motion=mo.select(mo.t <= t_row), range_bearing=rb.select(rb.t < t_row)))
    stamps = np.unique(rb.t[rb.t >= t_row])[: 1 + params["window"]]
    z = rb.z[rb.t == t_row]
    row, options = ekf.ambiguity(z)
    label = {
        lm: g for d, lm, _, g in ekf.assoc_log if d == 1
    }  # the id in the data of the row that created each landmark
    print("row", row, "labelled", int(z[row, 2]), "robot σ_xy %.1f m" % np.sqrt(np.trace(ekf.robot_cov[:2, :2])))
    for option in options.tolist():
        trial, t_prev = copy.deepcopy(ekf), t_row
        start = trial.log_likelihood
        trial.update(z, t_row, {row: option})
        for t in stamps[1:]:
            k = (mo.t > t_prev) & (mo.t <= t)
            trial.predict_increments(mo.delta[k], None if params.get("increment_cov") is not None else mo.cov[k])
            trial.update(rb.z[rb.t == t], t)
            t_prev = t
        print(
            "hypothesis",
            "new" if option < 0 else f"landmark created from tree {label[ekf.landmark_ids[option]]}",
            "window log-likelihood %.1f" % (trial.log_likelihood - start),
            "decisions",
            "".join("MNR"[d] for d, _, _, _ in trial.assoc_log[len(ekf.assoc_log) :]),
        )


if __name__ == "__main__":
    main()
