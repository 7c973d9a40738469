"""The pose_graphs config's graphs through ``PoseGraphOptimizer(max_iterations=500)``: who built each GTSAM graph and
the optimiser's start and end error and iterations, to compare with results.md's pose_graphs table (notebook
2026-11-28-gtsam-cost.md). cityTrees10000 and w20000 are left out (84 s and 59 s of LM, their graphs built from the
arrays either way).

Run from the repository root: ``OPENBLAS_NUM_THREADS=1 nice -n 10 .venv/bin/python research/scripts/gtsam_pose_graphs_check.py``.
"""

from __future__ import annotations

import time

GRAPHS = (
    "g2o:intel",
    "g2o:MIT",
    "g2o:CSAIL",
    "g2o:manhattan",
    "g2o:city10000",
    "isam:manhattanOlson3500",
    "isam:city10000",
    "g2o:ais2klinik",
)


def main() -> None:
    from slamarena import datasets
    from slamarena.estimators.gtsam_smoother import PoseGraphOptimizer

    for name in GRAPHS:
        graph = datasets.load(name)
        t = time.process_time()
        estimate = PoseGraphOptimizer(max_iterations=500).run(graph)
        d = estimate.diagnostics
        print(
            f"{name:26s} built by {estimate.meta['built_by']:14s} error {d['initial_error']:.3g} → "
            f"{d['final_error']:.4g}, {d['iterations']} iterations, {time.process_time() - t:.2f} s CPU",
            flush=True,
        )


if __name__ == "__main__":
    main()
