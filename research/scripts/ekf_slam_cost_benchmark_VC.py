"""notebook/2026-11-23-ekf-slam-cost-benchmark.md, script VC (VC)

Run from the repository root: ``OPENBLAS_NUM_THREADS=1 python research/scripts/ekf_slam_cost_benchmark_VC.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import time

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    cfg = load_config("victoria_park")
    seq = datasets.load("victoria_park")
    rows = {(e.label or e.name): e for e in cfg.estimators}
    for lab in ["ekf_slam_identified", "ekf_slam_nn_managed"]:
        t = time.process_time()
        est = EKFSLAM(**rows[lab].resolved_params()).run(seq)
        cpu = time.process_time() - t
        ref = Estimate.load(f"results/victoria_park/runs/victoria_park/{lab}/0/estimate.npz")
        print(
            lab,
            f"max |Δ pose xy| {np.abs(est.poses[:, :2] - ref.poses[:, :2]).max():.2e} m, landmarks {len(est.landmark_ids)} (cached {len(ref.landmark_ids)}), CPU {cpu:.0f} s",
        )


if __name__ == "__main__":
    main()
