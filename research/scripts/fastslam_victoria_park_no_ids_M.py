"""notebook/2026-11-23-fastslam-victoria-park-no-ids.md, script M (M)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_M.py '{"confirm_sightings": 3, "confirm_window": 10.0}' 0 1 2 3 4 5 6 7 8 9``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
import time

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    extra = eval(sys.argv[1])
    seq = datasets.load("victoria_park")
    isam = Estimate.load("results/victoria_park/runs/victoria_park/gtsam_isam2/0/estimate.npz")
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[
        "fastslam_no_ids_identified"
    ].resolved_params()
    params.pop("confirm_sightings", None)
    params.pop("confirm_window", None)  # the row without the rule; argv[1] adds it
    for seed in map(int, sys.argv[2:]):
        t0 = time.process_time()
        est = FastSLAM(**{**params, "seed": seed, **extra}).run(seq)
        cpu = time.process_time() - t0
        d = np.hypot(
            *(est.poses[:, :2] - interpolate_poses(isam.t, isam.poses, np.clip(est.t, isam.t[0], isam.t[-1]))[:, :2]).T
        )
        print(
            extra,
            f"seed {seed}: RMSE {np.sqrt(np.mean(d**2)):.1f} max {d.max():.1f} (t {est.t[d.argmax()]:.0f}) final {d[-1]:.1f} "
            f"landmarks {len(est.landmark_ids)} live per particle (end) {est.diagnostics['landmarks_mean'][-1]:.0f} CPU {cpu:.0f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
