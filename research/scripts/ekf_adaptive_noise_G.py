"""Victoria Park (or another sequence) without ids on the grid q = 4^i (i = 0…4), r = 4^−j (j = 0…2): landmarks, final
position, and the run's log-likelihood at several times (research/notebook/2026-11-28-ekf-adaptive-noise.md, script G).

    python research/scripts/ekf_adaptive_noise_G.py victoria_park
"""

import json
import runpy
import sys
from pathlib import Path

import numpy as np

from slamarena.estimators.ekf_slam import EKFSLAM


def main() -> None:
    name = sys.argv[1]
    params = json.loads(sys.argv[2]) if len(sys.argv) > 2 else {}
    seq = runpy.run_path(str(Path(__file__).with_name("ekf_adaptive_noise_W.py")))["sequence"](name)  # script W's

    class A(EKFSLAM):
        def _chain(self, delta, Q_body, Q_world, true_poses, anchor_shift=None):
            if Q_body is not None and len(Q_body):
                Q_body = np.asarray(Q_body) * qs
            return super()._chain(delta, Q_body, Q_world, true_poses, anchor_shift)

        def _valid(self, z, R):
            rows, Rz = super()._valid(z, R)
            return rows, Rz * rs

        def update(self, z, t=None, decide=None, R=None):
            super().update(z, t, decide, R)
            if not getattr(self, "_trial", False):
                ll.append((t, self.log_likelihood))

    res = {}
    for k in range(5):
        for j in range(3):
            qs, rs = 4.0**k, 4.0**-j
            ll = []
            ekf = A(**{"use_ids": False, **params})
            est = ekf.run(seq)
            L = np.array(ll)
            extra = ""
            if name == "victoria_park":
                extra = f" end {np.linalg.norm(est.poses[-1][:2] - [-13.99, 0.53]):.1f} m"
            if seq.ground_truth is not None:
                from slamarena.experiments.metrics import reference_of
                from slamarena.experiments.metrics.trajectory import ATEParams, ate

                extra += f" ATE {ate(est, reference_of(seq), ATEParams(align='se2', max_gap=0.25))[0]['rmse']:.3f}"
            marks = (
                [L[np.searchsorted(L[:, 0], q * L[-1, 0]) - 1, 1] for q in (0.02, 0.05, 0.1, 0.25, 0.5, 1.0)]
                if name != "victoria_park"
                else [L[np.searchsorted(L[:, 0], s) - 1, 1] for s in (100, 160, 200, 300, 500, 1e9)]
            )
            print(
                f"Q×{qs:g} R×{rs:g}: landmarks {len(est.landmark_ids)}{extra}, ll at marks "
                + " ".join(f"{m:.0f}" for m in marks),
                flush=True,
            )


if __name__ == "__main__":
    main()
