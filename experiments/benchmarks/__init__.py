"""Timing benchmarks, run with ``slamarena bench NAME``; never part of the test suite.

Each benchmark measures ratios within one run (ours vs a reference, or cost vs problem size
with a fitted log-log exponent), because absolute times on shared machines are noise.
``BENCHMARKS`` maps a name to ``"module:function"``; the function takes ``out`` (a
directory or ``None``) and ``quick`` (bool) and returns a process exit code.
"""
from __future__ import annotations

import importlib
from pathlib import Path

BENCHMARKS: dict[str, str] = {
    "readers": "experiments.benchmarks.readers:main",
    "ekf-slam": "experiments.benchmarks.ekf_slam:main",
    "isam2": "experiments.benchmarks.isam2:main",
    "grid": "experiments.benchmarks.grid:main",
    "scan-matching": "experiments.benchmarks.scan_matching:main",
}


def run_benchmark(name: str, out: Path | None = None, quick: bool = False) -> int:
    if name == "list":
        for key, target in BENCHMARKS.items():
            print(f"{key:16s} {target}")
        return 0
    if name not in BENCHMARKS:
        print(f"unknown benchmark {name!r}; known: {', '.join(BENCHMARKS)}")
        return 2
    module, _, attr = BENCHMARKS[name].partition(":")
    return int(getattr(importlib.import_module(module), attr)(out=out, quick=quick) or 0)
