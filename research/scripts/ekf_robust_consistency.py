"""EKF-SLAM's robust measurement update on the `consistency` config's hard world (4 laps, 30 landmarks, σω 0.1,
σb 2°), seeds 0…N−1: the N-run average NEES against the χ² band, per linearisation and robust kernel
(research/notebook/2026-11-28-ekf-defaults.md).

    python research/scripts/ekf_robust_consistency.py 10 none huber student_t
"""

import sys

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.metrics.consistency import monte_carlo, nees
from slamarena.experiments.metrics.reference import reference_of


def main():
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    kernels = sys.argv[2:] or ["none", "huber"]
    seqs = [
        datasets.load("sim:landmarks", seed=s, laps=4, n_landmarks=30, sigma_omega=0.1, sigma_bearing=0.0349)
        for s in range(seeds)
    ]
    for jac in ("standard", "fej", "oc"):
        for kernel in kernels:
            runs = []
            for seq in seqs:
                est = EKFSLAM(jacobians=jac, robust_update=kernel).run(seq)
                _, s = nees(est, reference_of(seq))
                runs.append((s["t"], s["nees"]))
            mc = monte_carlo(runs, dof=3)
            n = len(mc["mean"])
            print(
                jac,
                kernel,
                f"in_band {mc['in_band']:.3f} NEES/3 {mc['mean'].mean() / 3:.3f} late NEES/3 {mc['mean'][n // 2 :].mean() / 3:.3f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
