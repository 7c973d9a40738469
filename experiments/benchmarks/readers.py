"""``slamarena bench readers``: parse time of the vectorised readers as a ratio to reading the text.

For the Intel CARMEN log (16 MB of text, 2.6 M numbers) and UTIAS MRCLAM Dataset 6 (all five robots:
odometry, measurements, ground truth), the reference is what any reader must do anyway in the same
run: decompress the files and split them into lines. The ratio ``parse / (decompress + split)``
says how much the parsing (tokenising, numeric conversion, validation, building the Sequence) adds;
the aim is ≤ 3×. Reference and parse are timed alternately within each repeat, so that both see
the same machine load, and each timing is the minimum over the repeats (shared machines: minima
are the least noisy); the 1-minute load average is printed with the table.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from slamarena.datasets import load
from slamarena.datasets.catalogue import CATALOGUE
from slamarena.datasets.formats._text import read_bytes
from slamarena.experiments.benchmarks import write_rows


def _best_pair(reference, parse, repeats: int) -> tuple[float, float]:
    """Minimum times of ``reference()`` and ``parse()``, run alternately ``repeats`` times."""
    best = [float("inf"), float("inf")]
    for _ in range(repeats):
        for k, fn in enumerate((reference, parse)):
            start = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - start)
    return best[0], best[1]


def _split_only(paths: list[Path]) -> None:
    for p in paths:
        read_bytes(p).decode("latin-1").split("\n")


def cases() -> dict[str, tuple[list[str], list[Path]]]:
    mrclam = [f"utias:6/robot{k}" for k in range(1, 6)]
    return {
        "carmen:intel": (["carmen:intel"], list(CATALOGUE["carmen:intel"].paths().values())),
        "utias:6 (5 robots)": (mrclam, [p for n in mrclam for p in CATALOGUE[n].paths().values()]),
    }


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console
    from rich.table import Table

    repeats = 1 if quick else 5
    rows = []
    for label, (names, paths) in cases().items():
        baseline, parse = _best_pair(lambda: _split_only(paths), lambda: [load(n) for n in names], repeats)
        rows.append((label, baseline, parse, parse / baseline))
    load_avg = os.getloadavg()[0]
    table = Table(title=f"reader parse time vs decompress + line split (same run, min of {repeats}; load average {load_avg:.1f})")
    for col in ("dataset", "decompress+split [s]", "full parse [s]", "ratio (aim <= 3)"):
        table.add_column(col)
    for label, b, p, r in rows:
        table.add_row(label, f"{b:.3f}", f"{p:.3f}", f"{r:.2f}")
    Console().print(table)
    write_rows([{"dataset": l, "baseline_s": b, "parse_s": p, "ratio": r, "load_average": load_avg} for l, b, p, r in rows],
               out, "readers.csv")
    return 0
