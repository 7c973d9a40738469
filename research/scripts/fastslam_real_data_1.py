"""notebook/2026-11-22-fastslam-real-data.md, script 1

Run from the repository root: ``python research/scripts/fastslam_real_data_1.py results/victoria_park ekf_slam fastslam fastslam_no_ids dead_reckoning``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses


def main() -> None:
    runs = Path(sys.argv[1]) / "runs" / "victoria_park"
    ref = Estimate.load(runs / "ekf_slam" / "0" / "estimate.npz")
    print(
        "| run | landmarks | trees of the reference map within 2 m of one | distance from the reference path: RMSE / max [m] | at steps 400 / 450 / 500 / 1000 [m] | wall [s] |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for name in sys.argv[2:]:
        est = Estimate.load(runs / name / "0" / "estimate.npz")
        d = np.linalg.norm(
            est.poses[:, :2] - interpolate_poses(ref.t, ref.poses, np.clip(est.t, ref.t[0], ref.t[-1]))[:, :2], axis=1
        )
        at = " / ".join(f"{d[min(np.searchsorted(est.t, k), d.size - 1)]:.1f}" for k in (400, 450, 500, 1000))
        lm = np.zeros((0, 2)) if est.landmarks is None else est.landmarks.reshape(-1, 2)
        near, which = cKDTree(ref.landmarks).query(lm) if len(lm) else (np.zeros(0), np.zeros(0, int))
        print(
            f"| {name} | {len(lm)} | {np.unique(which[near < 2.0]).size} | {np.sqrt(np.mean(d**2)):.1f} / {d.max():.1f} | {at} | {est.step_time.sum():.0f} |"
        )


if __name__ == "__main__":
    main()
