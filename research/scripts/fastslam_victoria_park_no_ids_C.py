"""notebook/2026-11-23-fastslam-victoria-park-no-ids.md, script C (C)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_C.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses


def main() -> None:
    runs = "results/victoria_park/runs/victoria_park"
    isam = Estimate.load(f"{runs}/gtsam_isam2/0/estimate.npz")
    for name in ("ekf_slam_identified", "ekf_slam_nn_managed", "fastslam_identified", "fastslam_no_ids_identified"):
        e = Estimate.load(f"{runs}/{name}/0/estimate.npz")
        d = np.hypot(
            *(e.poses[:, :2] - interpolate_poses(isam.t, isam.poses, np.clip(e.t, isam.t[0], isam.t[-1]))[:, :2]).T
        )
        s = np.sqrt(np.trace(e.pose_cov[:, :2, :2], axis1=1, axis2=2))
        print(
            name,
            f"RMSE {np.sqrt(np.mean(d**2)):.1f} max {d.max():.1f} final {d[-1]:.1f} landmarks {len(e.landmark_ids)} |",
            " ".join(
                f"{t}: {np.interp(t, e.t, d):.1f}/{np.interp(t, e.t, s):.1f}"
                for t in (1000, 1130, 1300, 1390, 1398, 1420, 1450, 1500)
            ),
        )


if __name__ == "__main__":
    main()
