"""notebook/2026-11-22-fastslam-real-data.md, script 2

Run from the repository root: ``python research/scripts/fastslam_real_data_2.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import math
import time

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM


def main() -> None:
    seq = datasets.load("victoria_park")
    ident = dict(
        range_bearing_noise="cartesian",
        range_bearing_cov=[[0.025, 0.0], [0.0, 1.59e-4]],
        increment_cov=[[1.0e-4, 0.0, 0.0], [0.0, 4.096e-3, 0.0], [0.0, 0.0, 2.56e-4]],
    )
    refs = {
        n: Estimate.load(f"results/victoria_park/runs/victoria_park/{n}/0/estimate.npz")
        for n in ("ekf_slam", "gtsam_isam2")
    }
    for name, kw in [
        ("ids", ident),
        ("no ids, counters", dict(ident, use_ids=False, max_range=20.0, fov=math.pi)),
        ("no ids", dict(ident, use_ids=False)),
    ]:
        t0 = time.process_time()
        est = FastSLAM(version=2, particles=50, **kw).run(seq)
        cpu = time.process_time() - t0
        for rn, ref in refs.items():
            d = np.linalg.norm(
                est.poses[:, :2] - interpolate_poses(ref.t, ref.poses, np.clip(est.t, ref.t[0], ref.t[-1]))[:, :2],
                axis=1,
            )
            print(
                name,
                len(est.landmarks.reshape(-1, 2)),
                rn,
                f"{np.sqrt(np.mean(d**2)):.1f} / {d.max():.1f} / {d[-1]:.1f}",
                f"{cpu:.0f} s",
            )


if __name__ == "__main__":
    main()
