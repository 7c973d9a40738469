"""An iSAM2 answer the convergence rule accepts on MRCLAM Dataset 1 (robot given, default 2) against the batch optimum
of the same graph, in units of the batch's marginal σ (research/notebook/2026-11-28-gtsam-convergence.md).

    python research/scripts/gtsam_convergence_D1_sigma.py [robot]
"""

import sys

import numpy as np

from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.registry import load
from slamarena.estimators.gtsam_smoother import BatchSmoother, ISAM2Smoother

NOISE = dict(twist_cov=[0.0117624, 0.174], range_bearing_cov=[0.0225, 0.0004], robust="huber", max_interval=1.0)


def main():
    robot = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    seq = load("utias", path="utias_mrclam/MRCLAM_Dataset1", robot=robot)
    inc = ISAM2Smoother(**NOISE).run(seq)
    bat = BatchSmoother(max_iterations=500, **NOISE).run(seq, between_cov=inc.diagnostics["between_cov"])
    d = inc.poses - bat.poses
    d[:, 2] = wrap_angle(d[:, 2])
    poses = np.abs(d) / np.sqrt(np.diagonal(bat.pose_cov, axis1=1, axis2=2))
    points = np.abs(inc.landmarks - bat.landmarks) / np.sqrt(np.diagonal(bat.landmark_cov, axis1=1, axis2=2))
    print(
        f"D1 robot{robot}: iSAM2 ½χ² {inc.diagnostics['final_error']:.6f}, batch on iSAM2's graph "
        f"{bat.diagnostics['final_error']:.6f}; max |iSAM2 − batch| / σ: poses {poses.max():.4f}, landmarks "
        f"{points.max():.4f}; max |Δ position| {np.abs(d[:, :2]).max():.2e} m, heading {np.abs(d[:, 2]).max():.2e} rad"
    )


if __name__ == "__main__":
    main()
