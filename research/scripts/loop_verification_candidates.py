"""notebook/2026-11-28-loop-verification.md, "What did not work": every loop candidate of one drive by its test.

Run from the repository root: ``python research/scripts/loop_verification_candidates.py WORLD SEED [key=value ...]``
(laser_slam parameters as ``slamarena map`` takes them). Prints, per test that rejected a candidate ('' accepted), how
many candidates were false and true (the truth criterion of ``loop_verification.py``), the ATE, the windows, and one
letter per candidate in the order tried (A accepted, F accepted but false, s score, a ambiguous, c consistency,
G gnc, - search).
"""

import sys

import numpy as np

from slamarena.datasets.geometry import between
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.cli_map import parse_params
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM
from slamarena.mapping.laser_slam.loop_closure import TESTS

sys.path.insert(0, "research/scripts")
from loop_verification import DRIVE  # noqa: E402


def main() -> None:
    world, seed, params = sys.argv[1], int(sys.argv[2]), parse_params(sys.argv[3:])
    seq = simulate(world=world, seed=seed, **DRIVE)
    est = LaserSLAM(**params).run(seq)
    d = est.diagnostics
    truth = seq.ground_truth.poses[np.searchsorted(seq.ground_truth.t, seq.scans.t)][d["node_scan"]]
    found = np.isfinite(d["loop_z"][:, 0])
    err = np.full(found.size, np.nan)
    e = d["loop_z"][found] - between(truth[d["loop_anchor"][found]], truth[d["loop_node"][found]])
    err[found] = np.hypot(e[:, 0], e[:, 1])
    false = err > 1.0
    for t in ("",) + TESTS:
        m = d["loop_test"] == t
        print(f"test {t!r:14s} n {m.sum():4d} false {np.sum(m & false):4d} true {np.sum(m & ~false & found):4d}")
    print("ATE", ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"])
    print("window median/max", np.nanmedian(d["loop_window"]), np.nanmax(d["loop_window"]))
    letter = {"": "A", "search": "-", "score": "s", "ambiguous": "a", "consistency": "c", "gnc": "G"}
    print("".join("F" if t == "" and false[i] else letter[t] for i, t in enumerate(d["loop_test"])))


if __name__ == "__main__":
    main()
