"""notebook/2026-11-23-graph-slam-results.md, script P (P)

Run from the repository root: ``python research/scripts/graph_slam_results_P.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses


def main() -> None:
    runs = "results/victoria_park/runs/victoria_park"
    E = {
        k: Estimate.load(f"{runs}/{k}/0/estimate.npz")
        for k in (
            "gtsam_isam2",
            "gtsam_isam2_identified",
            "gtsam_batch_identified",
            "ekf_slam",
            "ekf_slam_identified",
            "ekf_slam_nn_managed",
            "ekf_slam_jcbb_managed",
            "fastslam_identified",
        )
    }
    for ref in ("gtsam_isam2", "gtsam_isam2_identified"):
        for k, e in E.items():
            r = E[ref]
            d = np.hypot(*(e.poses[:, :2] - interpolate_poses(r.t, r.poses, np.clip(e.t, r.t[0], r.t[-1]))[:, :2]).T)
            print(f"{k} vs {ref}: RMSE {np.sqrt(np.mean(d**2)):.2f} max {d.max():.2f} final {d[-1]:.2f} m")


if __name__ == "__main__":
    main()
