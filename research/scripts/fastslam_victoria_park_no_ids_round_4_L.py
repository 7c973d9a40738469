"""notebook/2026-11-23-fastslam-victoria-park-no-ids-round-4.md, script L (L (then '{"laps": 2, "n_landmarks": 200, "sigma_omega": 0.1}' 50 0 1 2))

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_round_4_L.py '{"laps": 2}' 50 0 1 2 3 4``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
It runs at commit b70c26a only (``git checkout b70c26a``, as the page says): the ``loop_gate`` option it compares was
measured, not shipped, and removed from the code after it.
"""

import sys
import time

import numpy as np

from slamarena import datasets
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def main() -> None:
    # SIM: FastSLAM 2.0 without ids on sim:landmarks loops, loop_gate particle against cloud (paired: same world, same filter seed)
    world, M = eval(sys.argv[1]), int(sys.argv[2])
    for seed in map(int, sys.argv[3:]):
        seq = datasets.load("sim:landmarks", **{**world, "seed": seed})
        ref = reference_of(seq)
        out = []
        for gate in ("particle", "cloud"):
            t0 = time.process_time()
            est = FastSLAM(version=2, particles=M, use_ids=False, loop_gate=gate, seed=0).run(seq)
            e = ate(est, ref, ATEParams(align="none"))[0]
            out.append(
                f"{gate}: ATE {e['rmse']:.3f} m, landmarks {len(est.landmark_ids)}, CPU {time.process_time() - t0:.0f} s"
            )
        print(
            f"{world} seed {seed} (n = {len(np.unique(seq.range_bearing.landmark_id))} seen): " + " | ".join(out),
            flush=True,
        )


if __name__ == "__main__":
    main()
