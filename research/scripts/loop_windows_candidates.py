"""notebook/2026-11-28-loop-windows.md: every loop candidate of laser graph SLAM on the ``loop_closure`` drive against the
truth.

Run from the repository root: ``python research/scripts/loop_windows_candidates.py SEED [key=value ...]`` (laser_slam
parameters as ``slamarena map`` takes them). Per candidate: the error of the estimate's X_c⁻¹ X_n (the window's centre)
against the truth and the window's half-widths (``IN`` when the window holds it); per matched loop: its constraint's
error against the truth, its σ, and the test that rejected it. A loop is false when its constraint is more than 1 m
or 0.1 rad from the truth (as in the loop-verification notebook). Ends with the ATE, the loops accepted and the
false ones among them.
"""

from __future__ import annotations

import sys

import numpy as np

from slamarena.datasets.geometry import between, se2_log
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.cli_map import parse_params
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam.loop_closure import LoopCloser, LoopRecord
from slamarena.mapping.laser_slam.slam import LaserSLAM

sys.path.insert(0, "research/scripts")
from loop_verification_long_loop import DRIVE  # noqa: E402


def main() -> None:
    seed, params = int(sys.argv[1]), parse_params(sys.argv[2:])
    seq = simulate(seed=seed, **DRIVE)
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    searched, covs = [], []
    try_close, add = LoopCloser.try_close, LoopRecord.add

    def hooked_try_close(self, submap, n, c, P, points, L, G, own):
        searched.append((n, c, G[c].copy(), G[n].copy(), self.window(P)))
        return try_close(self, submap, n, c, P, points, L, G, own)

    def hooked_add(self, *values, z, cov):
        covs.append(cov)
        return add(self, *values, z=z, cov=cov)

    LoopCloser.try_close, LoopRecord.add = hooked_try_close, hooked_add
    est = LaserSLAM(**params).run(seq)
    d, nodes = est.diagnostics, est.diagnostics["node_scan"]
    false = 0
    for j, (n, c, Gc, Gn, (linear, angular)) in enumerate(searched):
        e = se2_log(between(between(Gc, Gn), between(truth[nodes[c]], truth[nodes[n]])))
        inside = np.hypot(*e[:2]) <= linear and abs(e[2]) <= angular
        line = f"n={n:4d} c={c:4d} centre error {np.hypot(*e[:2]):5.2f} m {e[2]:+.3f} rad, window {linear:5.2f} m "
        line += f"{angular:.3f} rad {'IN ' if inside else 'OUT'}"
        if np.all(np.isfinite(d["loop_z"][j])):
            a = d["loop_anchor"][j]
            f = se2_log(between(d["loop_z"][j], between(truth[nodes[a]], truth[nodes[n]])))
            wrong = np.hypot(*f[:2]) > 1.0 or abs(f[2]) > 0.1
            false += bool(wrong and d["loop_test"][j] == "")
            sd = np.sqrt(np.diag(covs[j]))
            line += f" | loop to {a}: error ({f[0]:+.2f}, {f[1]:+.2f}, {f[2]:+.3f}) σ ({sd[0]:.2f}, {sd[1]:.2f}, {sd[2]:.3f})"
            line += f" {'FALSE ' if wrong else ''}{d['loop_test'][j] or 'accepted'}"
        else:
            line += f" | {d['loop_test'][j]}"
        print(line)
    rmse = ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"]
    print(f"seed {seed}: ATE {rmse:.3f} m, {est.meta['loop_closures']} accepted, {false} of them false; ", end="")
    print(f"rejected {est.meta['loop_rejected_by']}")


if __name__ == "__main__":
    main()
