"""One laser method on one staged log with parameter overrides, scored by the log's relations
(research/notebook/2026-11-28-degeneracy.md).

Usage: ``python research/scripts/degeneracy_2.py METHOD LOG [JSON_OVERRIDES] [--old-wrap]`` with METHOD grid_slam or
laser_slam, LOG intel, fr079, mit-csail or fr-clinic. ``--old-wrap`` replaces the Gauss-Newton matcher's
``wrap_angle`` by the formula it used before, ``(a + π) mod 2π − π`` (the branch-cut experiment).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def main(argv: list[str]) -> None:
    from slamarena import datasets
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
    from slamarena.mapping.grid_slam import GridSLAM
    from slamarena.mapping.laser_slam.slam import LaserSLAM
    from slamarena.mapping.scan_matching import gauss_newton

    old_wrap = "--old-wrap" in argv
    argv = [a for a in argv if a != "--old-wrap"]
    if old_wrap:
        if not hasattr(gauss_newton, "wrap_angle"):
            sys.exit(
                "--old-wrap: the matcher wraps with (a + π) mod 2π − π itself again (research/method/laser_degeneracy.md, "
                "'The branch cut'); the flag applies to the notebook's intermediate commit only"
            )
        gauss_newton.wrap_angle = lambda a: (a + np.pi) % (2 * np.pi) - np.pi
    method, log = argv[0], argv[1]
    overrides = json.loads(argv[2]) if len(argv) > 2 else {}
    seq = datasets.load(f"carmen:{log}")
    cpu = time.process_time()
    est = {"grid_slam": GridSLAM, "laser_slam": LaserSLAM}[method](**overrides).run(seq)
    cpu = time.process_time() - cpu
    relations = f"../shared/datasets/radish_laser_logs/relations/{log}.relations"
    scores, _ = relation_error_from_file(est, seq, RelationsParams(file=relations))
    print(
        f"{method} {log} {json.dumps(overrides)}{' old-wrap' if old_wrap else ''}: trans_mean {scores['trans_mean']:.4f} "
        f"± {scores['trans_std']:.4f}, local {scores['local_trans_mean']:.4f}, used {scores['used']}, cpu {cpu:.0f} s"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
