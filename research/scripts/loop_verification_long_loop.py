"""notebook/2026-11-28-loop-verification.md, "The simulated corridor loop": laser_slam on the loop_closure drive.

Run from the repository root: ``python research/scripts/loop_verification_long_loop.py SEEDS [key=value ...]``, e.g.
``0,4 loop.verify=none`` or ``1,2,3,5 loop.min_linear_window=5.0 loop.min_angular_window=0.5`` (laser_slam parameters
as ``slamarena map`` takes them). Prints per seed the ATE, the loops accepted and the rejections by test.
"""

import sys

from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.cli_map import parse_params
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM

#: the loop_closure config's long_loop drive
DRIVE = dict(
    world="long_loop",
    max_range=4.0,
    n_beams=91,
    sigma_range=0.02,
    k_r=0.06,
    k_rt=0.03,
    k_t=0.085,
    scan_rate=2.5,
    laps=2,
)


def main() -> None:
    seeds = [int(s) for s in sys.argv[1].split(",")]
    params = parse_params(sys.argv[2:])
    for seed in seeds:
        seq = simulate(seed=seed, **DRIVE)
        est = LaserSLAM(**params).run(seq)
        rmse = ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"]
        print(seed, round(rmse, 3), est.meta["loop_closures"], est.meta["loop_rejected_by"], flush=True)


if __name__ == "__main__":
    main()
