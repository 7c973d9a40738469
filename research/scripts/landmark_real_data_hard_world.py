"""FEJ and OC on the hard world of the `consistency` config (4 laps, 30 landmarks, σω 0.1, σb 2°), seeds 0…N−1, with
the anchor test at the given confidences ("None": the published filters): the N-run average NEES against the χ² band
(research/notebook/2026-11-28-landmark-real-data.md).

    python research/scripts/landmark_real_data_hard_world.py 10 None 0.999999999999
"""

import sys

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.experiments.metrics.consistency import monte_carlo, nees
from slamarena.experiments.metrics.reference import reference_of


def main():
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    confidences = [None if a == "None" else float(a) for a in sys.argv[2:]] or [None]
    seqs = [
        datasets.load("sim:landmarks", seed=s, laps=4, n_landmarks=30, sigma_omega=0.1, sigma_bearing=0.0349)
        for s in range(seeds)
    ]
    for jac in ("fej", "oc"):
        for c in confidences:
            runs, resets = [], 0
            for seq in seqs:
                est = EKFSLAM(jacobians=jac, anchor_confidence=c).run(seq)
                resets += est.meta["anchors_reset"]
                _, s = nees(est, reference_of(seq))
                runs.append((s["t"], s["nees"]))
            mc = monte_carlo(runs, dof=3)
            n = len(mc["mean"])
            print(
                jac, c, f"in_band {mc['in_band']:.3f} late NEES/3 {mc['mean'][n // 2 :].mean() / 3:.3f} resets {resets}"
            )


if __name__ == "__main__":
    main()
