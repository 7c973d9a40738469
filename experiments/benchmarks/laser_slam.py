"""``slamarena bench laser-slam``: laser graph SLAM's speed as a ratio to the log's duration, split into its parts.

For each staged log (Intel first; ``--quick``: Intel only), in one single-threaded child process (one BLAS
thread, one numba thread): the front end alone (:class:`~slamarena.mapping.grid_slam.GridSLAM`) and laser graph
SLAM with loop closure (:class:`~slamarena.mapping.laser_slam.LaserSLAM`), both with their defaults. Printed:
wall time, the real-time factor (log duration / wall time; the aim for Intel is ≥ 20 with loop closure; also with
the process's CPU time, which a loaded machine inflates less) and
laser SLAM's split (CPU time) into front end, pairwise ICP of the local refinement, loop-closure search and
optimisation (the node graph's and the refinement's), with the loop candidates tried and
accepted. The relation error is printed beside each, so a faster setting cannot hide a worse map.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from slamarena.experiments.benchmarks import aim, measure_single_threaded, table, write_rows

LOGS = ("intel", "fr079", "mit-csail", "fr-clinic")
#: each staged log is measured (``--quick``: Intel only); none staged: nothing to measure
STAGED_DATA: dict[str, bool] = {
    "carmen:intel": False,
    "carmen:fr079": False,
    "carmen:mit-csail": False,
    "carmen:fr-clinic": False,
}
AIM_REAL_TIME = 20.0


def measure(log: str) -> dict:
    """Run both methods on ``carmen:<log>`` (in this process) and return the timings and relation errors."""
    from slamarena import datasets
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
    from slamarena.mapping.grid_slam import GridSLAM
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = datasets.load(f"carmen:{log}")
    duration = float(seq.scans.t[-1] - seq.scans.t[0])
    row = {"log": log, "scans": len(seq.scans), "duration_s": duration}
    for name, method in (("grid_slam", GridSLAM()), ("laser_slam", LaserSLAM())):
        cpu, tic = time.process_time(), time.perf_counter()
        est = method.run(seq)
        wall, cpu = time.perf_counter() - tic, time.process_time() - cpu
        scores, _ = relation_error_from_file(est, seq, RelationsParams(match="interpolate"))
        row.update(
            {
                f"{name}_wall_s": wall,
                f"{name}_cpu_s": cpu,
                f"{name}_realtime": duration / wall,
                f"{name}_realtime_cpu": duration / cpu,
                f"{name}_trans_mean": scores["trans_mean"],
            }
        )
        if name == "laser_slam":
            row.update({f"laser_slam_{k}_s": v for k, v in est.meta["seconds"].items()})
            row.update(
                loop_candidates=est.meta["loop_candidates"],
                loop_closures=est.meta["loop_closures"],
                nodes=est.meta["nodes"],
            )
    return row


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    from slamarena.datasets.registry import resolve

    rows = [
        measure_single_threaded("slamarena.experiments.benchmarks.laser_slam", log=log)
        for log in (LOGS[:1] if quick else LOGS)
        if resolve(f"carmen:{log}").present()
    ]
    if not rows:
        print("no staged CARMEN log with relations (radish_laser_logs): nothing to measure")
        return 0
    speed = table(
        "laser SLAM speed, single-threaded: real-time factor = log duration / wall time",
        (
            "log",
            "grid SLAM ×RT wall / CPU",
            "laser SLAM ×RT wall / CPU",
            "front end [CPU s]",
            "pairwise ICP [CPU s]",
            "loop search [CPU s]",
            "optimisation [CPU s]",
            "loops accepted / tried",
            "rel. error grid / laser [m]",
        ),
        justify="right",
    )
    for r in rows:
        speed.add_row(
            r["log"],
            f"{r['grid_slam_realtime']:.1f} / {r['grid_slam_realtime_cpu']:.1f}",
            f"{r['laser_slam_realtime']:.1f} / {r['laser_slam_realtime_cpu']:.1f}",
            f"{r['laser_slam_front_end_s']:.1f}",
            f"{r['laser_slam_pairwise_s']:.1f}",
            f"{r['laser_slam_loop_search_s']:.1f}",
            f"{r['laser_slam_optimisation_s']:.1f}",
            f"{r['loop_closures']} / {r['loop_candidates']}",
            f"{r['grid_slam_trans_mean']:.3f} / {r['laser_slam_trans_mean']:.3f}",
        )
    console = Console()
    console.print(speed)
    intel = next((r for r in rows if r["log"] == "intel"), None)
    if intel is not None:
        console.print(
            f"laser SLAM with loop closure on Intel: {intel['laser_slam_realtime']:.1f}× real time (wall) "
            f"{aim(f'≥ {AIM_REAL_TIME:g}×', intel['laser_slam_realtime'] >= AIM_REAL_TIME)}",
            markup=False,
        )
    write_rows(rows, out, "laser_slam.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
