"""notebook/2026-11-23-fastslam-victoria-park-no-ids-round-4.md, script V (V)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_round_4_V.py fastslam_no_ids_identified 50 '{}' 0 1 2 3 4``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    # error from the EKF without ids and from iSAM2 of a row with M particles over seeds: first crossing of 5 m, RMSE/max/final
    label, M, extra = sys.argv[1], int(sys.argv[2]), eval(sys.argv[3])
    seq = datasets.load("victoria_park")
    runs = "results/victoria_park/runs/victoria_park"
    isam, ekf = (Estimate.load(f"{runs}/{n}/0/estimate.npz") for n in ("gtsam_isam2", "ekf_slam_nn_managed"))
    err = lambda e, ref: np.hypot(
        *(e.poses[:, :2] - interpolate_poses(ref.t, ref.poses, np.clip(e.t, ref.t[0], ref.t[-1]))[:, :2]).T
    )
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[label].resolved_params()
    for seed in map(int, sys.argv[4:]):
        est = FastSLAM(**{**params, "particles": M, "seed": seed, **extra}).run(seq)
        a, b = err(est, ekf), err(est, isam)
        print(
            f"{label} M {M} {extra} seed {seed}: > 5 m from the EKF without ids first at t = {est.t[np.argmax(a > 5)] if np.any(a > 5) else None}; "
            f"at 250/500/1000: {np.interp(250, est.t, a):.1f}/{np.interp(500, est.t, a):.1f}/{np.interp(1000, est.t, a):.1f}; vs iSAM2 RMSE/max/final "
            f"{np.sqrt(np.mean(b**2)):.1f}/{b.max():.1f}/{b[-1]:.1f}; landmarks {len(est.landmark_ids)}",
            flush=True,
        )


if __name__ == "__main__":
    main()
