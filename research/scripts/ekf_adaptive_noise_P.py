"""The ACFR Car Park's extracted beacons, ids withheld, every default but self_identify=True: every walk of the search
(its scales, log-likelihood, landmarks, rows decided by the look-ahead, CPU) and the run chosen, scored against the GPS
and the surveyed beacons as the carpark config scores (research/notebook/2026-11-28-ekf-adaptive-noise.md, script P).

    python research/scripts/ekf_adaptive_noise_P.py
"""

import time

from slamarena import datasets
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam import run as runmod
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.landmark_extraction import landmark_sequence


def main() -> None:
    seq = landmark_sequence(datasets.load("carpark"))
    ref = reference_of(seq)
    walk = runmod._walk

    def timed(ekf, s, q=1.0, r=1.0):
        t = time.process_time()
        e = walk(ekf, s, q, r)
        print(
            f"walk q={q:g} r={r:g}: L {ekf.log_likelihood:.0f}, landmarks {len(e.landmark_ids)}, looked ahead {e.meta['looked_ahead']}, cpu {time.process_time() - t:.1f} s",
            flush=True,
        )
        return e

    runmod._walk = timed
    est = EKFSLAM(use_ids=False, self_identify=True).run(seq)
    tr, _ = ate(est, ref, ATEParams(align="se2", max_gap=0.25))
    m, _ = landmark_error(est, ref, MapParams(by="nearest", max_distance=2.0, max_gap=0.25))
    print(
        "chosen",
        est.meta["noise_scale"],
        f"ATE {tr['rmse']:.4f} landmarks {len(est.landmark_ids)} map {m['rmse']:.3f} matched {m['matched']} spurious {m['spurious']}",
    )


if __name__ == "__main__":
    main()
