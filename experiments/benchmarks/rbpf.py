"""``slamarena bench rbpf``: speed, memory and accuracy of the grid RBPF (:mod:`slamarena.mapping.rbpf`) on the logs.

Each log runs in a child process of its own with one BLAS thread (:func:`measure_single_threaded`), so its
CPU time is one core's and its peak resident memory is that run's. Printed per log, as ratios:

* **real-time factor** = the log's duration / the filter's CPU time (≥ 1: faster than the robot recorded it),
  and the same with the wall time (the machine's load included);
* **particle-scans per second** = particles × scans / CPU time;
* **memory per particle** = the bytes of the map tiles in use (every level) and of the tile tables, divided
  by the particles, and **sharing** = what unshared copies of the same tiles would take / that;
  the process's **peak memory** (VmHWM);
* the **relation error** (Kümmerle et al. 2009) against the log's relations file when staged.

Full run: Intel, FR079, MIT-CSAIL and FR-Clinic, whole logs, 30 particles (the issue's speed goal: Intel at
least real time on one core). ``--quick``: the first 2000 scans of Intel.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from slamarena.experiments.benchmarks import aim, measure_single_threaded, table, write_rows

LOGS = ("intel", "fr079", "mit-csail", "fr-clinic")
#: Intel is measured by ``--quick`` and the full run; the other logs by the full run only
STAGED_DATA: dict[str, bool] = {
    "carmen:intel": True,
    "carmen:fr079": False,
    "carmen:mit-csail": False,
    "carmen:fr-clinic": False,
}
PARTICLES = 30
AIM_REAL_TIME = 1.0


def measure(log: str, particles: int, scans: int | None = None) -> dict:
    """One RBPF run on ``carmen:<log>`` (its first ``scans`` scans when given), in this process."""
    import dataclasses

    import numpy as np

    from slamarena import datasets
    from slamarena.experiments.metrics.cost import peak_rss_mb
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
    from slamarena.mapping.rbpf import RBPF

    seq = datasets.load(f"carmen:{log}")
    if scans is not None and scans < len(seq.scans):
        ipc = np.asarray(seq.meta["scan_ipc_timestamp"])[:scans]
        seq = dataclasses.replace(
            seq, scans=seq.scans.select(slice(0, scans)), meta={**seq.meta, "scan_ipc_timestamp": ipc}
        )
    rbpf = RBPF(particles=particles)
    rbpf.run(dataclasses.replace(seq, scans=seq.scans.select(slice(0, 20))))  # compile the kernels outside the timing
    cpu, wall = time.process_time(), time.perf_counter()
    est = rbpf.run(seq)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    duration = float(seq.scans.t[-1] - seq.scans.t[0])
    m = est.meta
    row = {
        "log": log,
        "scans": len(seq.scans),
        "particles": particles,
        "duration_s": duration,
        "cpu_s": cpu,
        "wall_s": wall,
        "real_time_factor_cpu": duration / cpu,
        "real_time_factor_wall": duration / wall,
        "particle_scans_per_s": particles * len(seq.scans) / cpu,
        "memory_per_particle_MB": m["memory_per_particle"] / 1e6,
        "memory_per_particle_peak_MB": m["memory_per_particle_peak"] / 1e6,
        "unshared_per_particle_MB": m["memory_unshared_per_particle"] / 1e6,
        "sharing": m["memory_unshared_per_particle"] / m["memory_per_particle"],
        "peak_rss_MB": peak_rss_mb(),
        "filter_steps": m["filter_steps"],
        "resampling_events": m["resampling_events"],
        "proposal_fallbacks": m["proposal_fallbacks"],
    }
    if seq.meta.get("relations"):  # the log's staged relations, read with it
        r, _ = relation_error_from_file(est, seq, RelationsParams(match="interpolate"))
        row.update({f"relations_{k}": v for k, v in r.items()})
    return row


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    console = Console(width=160)
    runs = [("intel", 2000)] if quick else [(log, None) for log in LOGS]
    rows = []
    for log, scans in runs:
        console.print(
            f"rbpf on carmen:{log} ({PARTICLES} particles{'' if scans is None else f', first {scans} scans'}) …"
        )
        rows.append(
            measure_single_threaded("slamarena.experiments.benchmarks.rbpf", log=log, particles=PARTICLES, scans=scans)
        )
    runs_table = table(
        f"grid RBPF, {PARTICLES} particles, one core per run",
        (
            "log",
            "scans",
            "log [s]",
            "CPU [s]",
            "× real time (CPU)",
            "× real time (wall)",
            "particle-scans / s",
            "MB / particle",
            "sharing",
            "peak RSS [MB]",
            "resamplings / steps",
            "relations: trans. [m]",
            "rot. [rad]",
        ),
    )
    for r in rows:
        rel = (
            (
                f"{r['relations_trans_mean']:.3f} ± {r['relations_trans_std']:.3f}",
                f"{r['relations_rot_mean']:.4f} ± {r['relations_rot_std']:.4f}",
            )
            if "relations_trans_mean" in r
            else ("—", "—")
        )
        runs_table.add_row(
            r["log"],
            str(r["scans"]),
            f"{r['duration_s']:.0f}",
            f"{r['cpu_s']:.1f}",
            f"{r['real_time_factor_cpu']:.1f}",
            f"{r['real_time_factor_wall']:.1f}",
            f"{r['particle_scans_per_s']:.0f}",
            f"{r['memory_per_particle_MB']:.2f}",
            f"{r['sharing']:.1f}×",
            f"{r['peak_rss_MB']:.0f}",
            f"{r['resampling_events']} / {r['filter_steps']}",
            *rel,
        )
    console.print(runs_table)
    write_rows(rows, out, "rbpf.csv")
    intel = next(r for r in rows if r["log"] == "intel")
    met = intel["real_time_factor_cpu"] >= AIM_REAL_TIME
    console.print(
        f"Intel with {PARTICLES} particles: {intel['real_time_factor_cpu']:.1f}× real time on one core "
        f"{aim(f'≥ {AIM_REAL_TIME:g}×', met)}",
        markup=False,
    )
    return 0 if met else 1


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
