"""FEJ and OC with and without the anchor test over 8 seeds of regime 2 of the consistency notebook (the slow test
test_oc_is_consistent_over_a_monte_carlo's world): the 8-run average NEES against the 95 % χ² band
(research/notebook/2026-11-28-landmark-real-data.md).

    python research/scripts/landmark_real_data_anchor_mc.py fej,oc
"""

import sys

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.metrics.consistency import monte_carlo, nees
from slamarena.experiments.metrics.reference import reference_of


def main():
    for jac in (sys.argv[1] if len(sys.argv) > 1 else "fej,oc").split(","):
        for anchor in (0.99999, None):
            runs, resets = [], 0
            for seed in range(8):
                seq = datasets.load(
                    "sim:landmarks", seed=seed, laps=1, n_landmarks=30, sigma_omega=0.1, sigma_bearing=0.0349
                )
                est = EKFSLAM(jacobians=jac, anchor_confidence=anchor).run(seq)
                resets += est.meta["anchors_reset"]
                _, series = nees(est, reference_of(seq))
                runs.append((series["t"], series["nees"]))
            mc = monte_carlo(runs, dof=3)
            print(jac, anchor, f"in_band {mc['in_band']:.3f} mean NEES/3 {mc['mean'].mean() / 3:.3f} resets {resets}")


if __name__ == "__main__":
    main()
