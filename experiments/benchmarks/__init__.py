"""Timing benchmarks, run with ``slamarena bench NAME``; never part of the test suite.

Each benchmark measures ratios within one run (ours vs a reference, or cost vs problem size
with a fitted log-log exponent), because absolute times on shared machines are noise.
``BENCHMARKS`` maps a name to ``"module:function"``; the function takes ``out`` (a
directory or ``None``) and ``quick`` (bool) and returns a process exit code.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

from slamarena.targets import import_target

BENCHMARKS: dict[str, str] = {
    "readers": "slamarena.experiments.benchmarks.readers:main",
    "ekf-slam": "slamarena.experiments.benchmarks.ekf_slam:main",
    "isam2": "slamarena.experiments.benchmarks.isam2:main",
    "grid": "slamarena.experiments.benchmarks.grid:main",
    "scan-matching": "slamarena.experiments.benchmarks.scan_matching:main",
    "laser-slam": "slamarena.experiments.benchmarks.laser_slam:main",
    "rbpf": "slamarena.experiments.benchmarks.rbpf:main",
    "fastslam": "slamarena.experiments.benchmarks.fastslam:main",
    "first-run": "slamarena.experiments.benchmarks.first_run:main",
}


def run_benchmark(name: str, out: Path | None = None, quick: bool = False) -> int:
    if name == "list":
        for key, target in BENCHMARKS.items():
            print(f"{key:16s} {target}")
        return 0
    if name not in BENCHMARKS:
        print(f"unknown benchmark {name!r}; known: {', '.join(BENCHMARKS)}")
        return 2
    return int(import_target(BENCHMARKS[name])(out=out, quick=quick) or 0)


def loglog_slope(rows: list[dict], key: str, lo: float, hi: float, size: str = "n") -> float:
    """Fitted exponent k of ``row[key] ∝ row[size]^k`` over the rows with ``lo <= size <= hi``."""
    import numpy as np

    pts = [(r[size], r[key]) for r in rows if lo <= r[size] <= hi and r.get(key)]
    return float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])


#: environment of a process whose BLAS, OpenMP and numba use one thread
SINGLE_THREAD_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}


def measure_single_threaded(module: str, **kwargs) -> dict:
    """Run ``module``'s ``measure(**kwargs)`` in a child process whose BLAS and numba use one thread.

    The module prints ``json.dumps(measure(**json.loads(argv[1])))`` as its last line when run
    with ``python -m``; one thread keeps per-step CPU times comparable on a shared machine.
    """
    env = {**os.environ, **SINGLE_THREAD_ENV}
    done = subprocess.run(
        [sys.executable, "-m", module, json.dumps(kwargs)], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def write_rows(rows: list[dict], out: Path | None, name: str) -> Path | None:
    """Write benchmark rows (dicts; a key missing in a row is left empty) to ``out/name`` as CSV and say
    where; nothing when ``out`` is None."""
    if out is None:
        return None
    path = Path(out) / name
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    return path
