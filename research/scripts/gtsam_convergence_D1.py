"""GTSAM batch and iSAM2 with the shipped mrclam parameters on one MRCLAM dataset, robots 1-5 (or those given):
converged or OptimizationError (research/notebook/2026-11-28-gtsam-convergence.md).

    python research/scripts/gtsam_convergence_D1.py 1 [robot ...]
"""

import sys
import time

from slamarena.datasets.registry import load
from slamarena.estimators import create
from slamarena.estimators.gtsam_smoother import OptimizationError

NOISE = dict(twist_cov=[0.0117624, 0.174], range_bearing_cov=[0.0225, 0.0004], robust="huber", max_interval=1.0)
METHODS = {"gtsam_batch": dict(NOISE, max_iterations=500), "gtsam_isam2": dict(NOISE)}


def main():
    dataset = sys.argv[1]
    robots = [int(a) for a in sys.argv[2:]] or [1, 2, 3, 4, 5]
    for k in robots:
        seq = load("utias", path=f"utias_mrclam/MRCLAM_Dataset{dataset}", robot=k)
        for name, params in METHODS.items():
            tic = time.process_time()
            try:
                d = create(name, **params).run(seq).diagnostics
                print(
                    f"D{dataset} robot{k} {name}: converged, final ½χ² {d['final_error']:.6g}, "
                    f"iterations {d.get('iterations', d.get('final_updates_used'))}, "
                    f"final_change {d.get('final_change', '-')}, cpu {time.process_time() - tic:.0f} s",
                    flush=True,
                )
            except OptimizationError as exc:
                print(f"D{dataset} robot{k} {name}: OptimizationError: {exc} (cpu {time.process_time() - tic:.0f} s)")


if __name__ == "__main__":
    main()
