"""notebook/2026-11-23-fastslam-victoria-park-no-ids-round-5.md, script A (A (then fastslam_identified 0 50 200; fastslam_no_ids_identified 1 1000 500))

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_round_5_A.py fastslam_no_ids_identified 0 50 200 500 1000``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np
from scipy.spatial import cKDTree

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    # A: FastSLAM on Victoria Park over particle counts: distance from iSAM2, the cloud's spread against the EKF's, and the
    # particles' common ancestor (diagnostics["common_ancestor_t"]) against the first visit of the places they return to
    label, seed = sys.argv[1], int(sys.argv[2])
    seq = datasets.load("victoria_park")
    runs = "results/victoria_park/runs/victoria_park"
    isam, ekf = (Estimate.load(f"{runs}/{n}/0/estimate.npz") for n in ("gtsam_isam2", "ekf_slam_nn_managed"))
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[label].resolved_params()
    sd_xy = lambda e: np.sqrt(np.trace(e.pose_cov[:, :2, :2], axis1=1, axis2=2))
    # a return: iSAM2's path within 5 m of where it was more than 300 steps before; the first visit: the earliest such step
    xy = isam.poses[:, :2]
    tree = cKDTree(xy)
    first = np.array(
        [
            min((j for j in tree.query_ball_point(xy[i], 5.0) if isam.t[j] < isam.t[i] - 300), default=-1)
            for i in range(len(xy))
        ]
    )
    for M in map(int, sys.argv[3:]):
        est = FastSLAM(**{**params, "particles": M, "seed": seed}).run(seq)
        ref = interpolate_poses(isam.t, isam.poses, np.clip(est.t, isam.t[0], isam.t[-1]))
        err = np.hypot(*(est.poses[:, :2] - ref[:, :2]).T)
        d = est.diagnostics
        t, tA = d["neff_t"], d["common_ancestor_t"]
        at = np.searchsorted(isam.t, t).clip(0, len(xy) - 1)
        ret = first[at] >= 0
        t_first = isam.t[first[at[ret]]]
        k = [np.searchsorted(est.t, s) for s in (1000, 2000, 3000)]
        print(
            f"{label} M {M} seed {seed}: RMSE/max/final {np.sqrt(np.mean(err**2)):.1f}/{err.max():.1f}/{err[-1]:.1f} m, landmarks {len(est.landmark_ids)}, "
            f"resamplings {est.meta['resamplings']} of {t.size} updates, median N_eff {np.median(d['neff']):.1f}; sd_xy at steps 1000/2000/3000 "
            f"{'/'.join(f'{sd_xy(est)[i]:.2f}' for i in k)} m (EKF without ids {'/'.join(f'{sd_xy(ekf)[np.searchsorted(ekf.t, s)]:.2f}' for s in (1000, 2000, 3000))}); "
            f"depth t - t_A median/95th percentile {np.median(t - tA):.0f}/{np.percentile(t - tA, 95):.0f} steps; updates at returns {ret.sum()}, "
            f"first visit before t_A at {np.mean(tA[ret] > t_first):.1%} of them; time since the first visit at returns: median {np.median(t[ret] - t_first):.0f} steps",
            flush=True,
        )


if __name__ == "__main__":
    main()
