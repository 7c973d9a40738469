"""Timing benchmarks, run with ``slamarena bench NAME``; never part of the test suite.

Each benchmark measures ratios within one run (ours vs a reference, or cost vs problem size
with a fitted log-log exponent), because absolute times on shared machines are noise.
``BENCHMARKS`` maps a name to ``"module:function"``; the function takes ``out`` (a
directory or ``None``) and ``quick`` (bool) and returns a process exit code. Each benchmark module's
docstring starts with ``slamarena bench NAME``: and a one-line description, and the module declares
``STAGED_DATA`` (a literal dict): the staged datasets it reads, each ``True`` when required (the benchmark cannot run
without it) or ``False`` when used only if staged; ``slamarena bench list`` shows both
(:func:`listing`), read from the module's source without importing it.

Output shared by every benchmark: :func:`table` (a rich table whose title and headers are text, not
markup: ``[ms]`` stays) and :func:`aim` (an aim always printed with its verdict: met, not met, or not
measurable at this size).
"""

from __future__ import annotations

import ast
import csv
import importlib.util
import json
import os
import re
import subprocess
import sys
from collections.abc import Iterable
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
    "scale": "slamarena.experiments.benchmarks.scale:main",
    "fastslam": "slamarena.experiments.benchmarks.fastslam:main",
    "gtsam": "slamarena.experiments.benchmarks.gtsam:main",
    "vision": "slamarena.experiments.benchmarks.vision:main",
    "vision-vo": "slamarena.experiments.benchmarks.vision_vo:main",
    "first-run": "slamarena.experiments.benchmarks.first_run:main",
}


def describe(name: str) -> tuple[str, dict[str, bool] | None]:
    """The one-line description of benchmark ``name`` (its module docstring's first sentence, without the
    ``slamarena bench NAME``: prefix) and its ``STAGED_DATA`` (None when the module declares none), read from the
    module's source without importing it."""
    module = BENCHMARKS[name].partition(":")[0]
    tree = ast.parse(Path(importlib.util.find_spec(module).origin).read_text())
    doc = " ".join((ast.get_docstring(tree) or "").split("\n\n")[0].split())
    doc = doc.removeprefix(f"``slamarena bench {name}``:").strip()
    doc = re.sub(r"(:\w+:)?`+([^`]+)`+", r"\2", doc)  # reStructuredText roles and literals as plain text
    data = None
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
        if any(isinstance(t, ast.Name) and t.id == "STAGED_DATA" for t in targets):
            data = ast.literal_eval(node.value)
    return doc, data


def staged_data_line(data: dict[str, bool] | None) -> str:
    """What a benchmark's ``STAGED_DATA`` asks for and whether each dataset is staged here."""
    from slamarena.datasets.registry import resolve

    if data is None:
        return "staged data: not declared"
    if not data:
        return "staged data: none (simulated or generated in the run)"

    def state(name: str) -> str:
        return f"{name} ({'present' if resolve(name).present() else 'absent'})"

    parts = []
    needed = [state(n) for n, required in data.items() if required]
    optional = [state(n) for n, required in data.items() if not required]
    if needed:
        parts.append("needs " + ", ".join(needed))
    if optional:
        parts.append("uses when staged " + ", ".join(optional))
    return "staged data: " + "; ".join(parts)


def listing() -> list[str]:
    """``slamarena bench list``: per benchmark its name, one-line description and staged data (present or absent)."""
    lines = []
    for name in BENCHMARKS:
        doc, data = describe(name)
        lines += [name, f"    {doc}", f"    {staged_data_line(data)}"]
    return lines


def run_benchmark(name: str, out: Path | None = None, quick: bool = False) -> int:
    if name == "list":
        print("\n".join(listing()))
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


def table(title: str, columns: Iterable[str], justify: str = "left"):
    """A rich ``Table`` with the given title and column headers as plain text (rich would read ``[ms]`` as markup
    and drop it)."""
    from rich.markup import escape
    from rich.table import Table

    out = Table(title=escape(title))
    for column in columns:
        out.add_column(escape(column), justify=justify)
    return out


#: the verdict of an aim: met, not met, or None when the run's sizes cannot show it
VERDICTS = {True: "met", False: "not met", None: "not measurable at this size"}


def verdict(met: bool | None) -> str:
    return VERDICTS[None if met is None else bool(met)]


def aim(target: str, met: bool | None, why: str = "") -> str:
    """``(aim TARGET: VERDICT)``, the one way a benchmark states an aim: ``met`` is True, False, or None when the
    measured sizes cannot show it (``why`` then says what would)."""
    return f"(aim {target}: {verdict(met)}{f', {why}' if met is None and why else ''})"
