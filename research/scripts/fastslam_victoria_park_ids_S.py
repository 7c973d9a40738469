"""notebook/2026-11-23-fastslam-victoria-park-ids.md, script S (S)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_ids_S.py '{}' 0 1 2 3 4 5 6 7 8 9``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM, kernels
from slamarena.experiments.config import load_config


def main() -> None:
    extra = eval(sys.argv[1])
    rule = extra.pop("_rule", None)
    seq = datasets.load("victoria_park")
    isam = Estimate.load("results/victoria_park/runs/victoria_park/gtsam_isam2/0/estimate.npz")
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[
        "fastslam_identified"
    ].resolved_params()
    if (
        rule == "all"
    ):  # a labelled row is an outlier when it is beyond the gate in every particle that has mapped its tree

        def _gated(self, z, slots, R, xhat, P):
            d2 = kernels.predictive_d2(
                xhat,
                P,
                np.ascontiguousarray(z[:, :2]),
                slots,
                self.n_slots,
                R,
                self.store.depth,
                self.store.roots,
                self.store.inner_child,
                self.store.leaf_mu,
                self.store.leaf_S,
            )
            out = np.all(np.isnan(d2) | (d2 > self.gate_known), axis=0) & ~np.all(np.isnan(d2), axis=0)
            self.rejected["gate"] += int(out.sum())
            return z[~out], slots[~out], R[~out]

        FastSLAM._gated = _gated
    for seed in map(int, sys.argv[2:]):
        est = FastSLAM(**{**params, "seed": seed, **extra}).run(seq)
        d = np.hypot(
            *(est.poses[:, :2] - interpolate_poses(isam.t, isam.poses, np.clip(est.t, isam.t[0], isam.t[-1]))[:, :2]).T
        )
        print(
            extra,
            rule,
            f"seed {seed}: RMSE {np.sqrt(np.mean(d**2)):.1f} max {d.max():.1f} final {d[-1]:.1f} rejected {int(est.diagnostics['rejected_gate'])}",
        )


if __name__ == "__main__":
    main()
