"""notebook/2026-11-28-loop-verification.md: laser graph SLAM on the aliasing world and its twin without aliasing.

Run from the repository root: ``python research/scripts/loop_verification.py [seeds, e.g. 2,3] [key=value ...]`` (the values
are laser_slam parameters as ``slamarena map`` takes them, e.g. ``loop.verify=none``). For each drive of
``aliased_rooms`` and ``distinct_rooms`` (the same route, odometry and range noise) it prints the loop candidates
tried, the loops accepted, how many accepted loops are false (their relative pose more than 1 m or 0.1 rad from the
ground truth's), the rejections by test, and the ATE.
"""

import sys

import numpy as np

from slamarena.datasets.geometry import between, wrap_angle
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.cli_map import parse_params
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM

#: the drive: the loop_closure config's long_loop drive (noisy odometry, two laps) with an 8 m laser that sees into the rooms
DRIVE = dict(max_range=8.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=0.085, scan_rate=2.5, laps=2)


def false_loops(seq, est) -> np.ndarray:
    """Per accepted loop, whether its constraint is false (> 1 m or > 0.1 rad from the true relative pose)."""
    d = est.diagnostics
    node_scan = d["node_scan"]
    truth = seq.ground_truth.poses[np.searchsorted(seq.ground_truth.t, seq.scans.t)]
    ok = d["loop_accepted"]
    a, n, z = d["loop_anchor"][ok], d["loop_node"][ok], d["loop_z"][ok]
    true = between(truth[node_scan[a]], truth[node_scan[n]])
    err = z - true
    return (np.hypot(err[:, 0], err[:, 1]) > 1.0) | (np.abs(wrap_angle(err[:, 2])) > 0.1)


def main() -> None:
    seeds = [int(x) for x in sys.argv[1].split(",")] if len(sys.argv) > 1 else [2, 3]
    params = parse_params(sys.argv[2:]) if len(sys.argv) > 2 else {}
    for seed in seeds:
        for world in ("aliased_rooms", "distinct_rooms"):
            seq = simulate(world=world, seed=seed, **DRIVE)
            est = LaserSLAM(**params).run(seq)
            rmse = ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"]
            m = est.meta
            rejected = {k: v for k, v in m.get("loop_rejected_by", {}).items() if v}
            print(
                f"seed {seed} {world:15s} candidates {m['loop_candidates']:4d} accepted {m['loop_closures']:4d} "
                f"false {int(false_loops(seq, est).sum()):3d} rejected {rejected} ATE {rmse:.3f} m",
                flush=True,
            )


if __name__ == "__main__":
    main()
