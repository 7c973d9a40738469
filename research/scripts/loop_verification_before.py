"""notebook/2026-11-28-loop-verification.md, "Before": main's laser_slam (8e01024) on the aliasing worlds.

Run from the main checkout with its own interpreter, naming this worktree's simulator file (main has no such worlds, so
``room_corridor`` is read from it and the worlds are passed as ``World`` objects):
``cd /work/main && .venv/bin/python /work/wt-loopverify/research/scripts/loop_verification_before.py
/work/wt-loopverify/datasets/sim/laser.py 2,3 [submap]``.
"""

import sys

import numpy as np

from slamarena.datasets.geometry import between, wrap_angle
from slamarena.datasets.sim import laser
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM

#: loop_verification.py's drive
DRIVE = dict(max_range=8.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=0.085, scan_rate=2.5, laps=2)


def main() -> None:
    src = open(sys.argv[1]).read()
    ns = {"np": np, "World": laser.World}
    exec(src[src.index("def room_corridor") : src.index("#: world name → World")], ns)
    tracking = {"tracking": "submap"} if sys.argv[3:] == ["submap"] else {}
    for seed in (int(s) for s in sys.argv[2].split(",")):
        for aliased in (True, False):
            world = ns["room_corridor"](
                56.0, 36.0, aliased=aliased, name="aliased_rooms" if aliased else "distinct_rooms"
            )
            seq = laser.simulate(world=world, seed=seed, **DRIVE)
            est = LaserSLAM(**tracking).run(seq)
            d = est.diagnostics
            ok, ns_ = d["loop_accepted"], d["node_scan"]
            truth = seq.ground_truth.poses[np.searchsorted(seq.ground_truth.t, seq.scans.t)]
            e = d["loop_z"][ok] - between(truth[ns_[d["loop_anchor"][ok]]], truth[ns_[d["loop_node"][ok]]])
            false = int(((np.hypot(e[:, 0], e[:, 1]) > 1) | (np.abs(wrap_angle(e[:, 2])) > 0.1)).sum())
            rmse = ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"]
            print(
                f"before seed {seed} {world.name:15s} candidates {ok.size} accepted {ok.sum()} false {false} ATE {rmse:.3f}"
            )


if __name__ == "__main__":
    main()
