"""``slamarena bench readers``: parse time of the vectorised readers as a ratio to reading the text,
and what the readers would cost with numpy's or pandas' C parser doing their number conversion.

For the Intel CARMEN log (16 MB of text, 2.6 M numbers) and UTIAS MRCLAM Dataset 6 (all five robots:
odometry, measurements, ground truth), the reference is what any reader must do anyway in the same
run: decompress the files and split them into lines. The ratio ``parse / (decompress + split)``
says how much the parsing (tokenising, numeric conversion, validation, building the Sequence) adds;
the aim is ≤ 3×.

**The alternatives.** Every number a text reader converts goes through one call of
:func:`slamarena.datasets.formats._text._parse_tokens` per record type (pandas' C parser on the
tokens as one column, numpy's parser for what it rejects), on one run of numeric text: the joined bodies of :func:`_text.numbers`
or the data lines of :func:`_text.numeric_table`. One load per case records those calls; then the
conversion step alone is timed on exactly those texts, by

- ``own``: ``_parse_tokens`` as the reader calls it;
- ``np.fromstring``: ``np.fromstring(text, sep=" ")`` with the DeprecationWarning (numpy's signal
  for a non-number) raised and the count checked — the reader's own fallback, :func:`_text._parse_row`;
- ``np.loadtxt``: ``np.loadtxt(BytesIO(text), ndmin=2)`` (checks the field count of every row;
  only for record types whose rows all have the same count);
- ``pandas high`` / ``pandas round_trip``: ``pandas.read_csv(BytesIO(text), sep=r"\\s+",
  header=None, names=range(width), dtype=float64, engine="c")`` with the default
  ``float_precision`` ("high") or ``float_precision="round_trip"`` (too many fields raise),
  flattened to the reader's value order (rows of different counts: NaN padding dropped by a
  mask). pandas 3.1 deprecates ``float_precision``: every mode uses one converter (fast_float,
  correctly rounded); in pandas 2.x "high" is pandas' own ``precise_xstrtod`` and "round_trip"
  Python's ``PyOS_string_to_double``.

Field counts, line numbers and the rest of the reader stay as they are (they come from the byte
scan, which every variant keeps), so the reader with an alternative costs
``full − own + alternative``; the table gives each as a ratio to the reference. All timings are
minima over the repeats, run alternately within each repeat so that all see the same machine load;
the 1-minute load average is printed with the table. A process that loads a dataset once (an
experiment cell) would also pay for importing pandas, which the data layer does not import today:
one more row adds that import time (minimum over fresh interpreters that have imported numpy).

**Exactness.** Every converted token is also converted by Python's ``float()`` (correctly rounded,
like ``strtod``), and the table counts the tokens on which each parser's double differs in any bit.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from slamarena.datasets import load
from slamarena.datasets.formats import _text
from slamarena.datasets.formats._text import read_bytes
from slamarena.datasets.registry import resolve
from slamarena.experiments.benchmarks import table, verdict, write_rows

STAGED_DATA: dict[str, bool] = {
    "carmen:intel": True,
    "utias:6/robot1": True,
    "utias:6/robot2": True,
    "utias:6/robot3": True,
    "utias:6/robot4": True,
    "utias:6/robot5": True,
}
AIM_RATIO = 3.0


class Body:
    """One conversion call of a reader: its numeric text and the field count of each of its rows."""

    def __init__(self, blob: bytes, b: np.ndarray, starts: np.ndarray, ends: np.ndarray, run: bool):
        self.args = (blob, b, starts, ends, run)
        if not run:  # every reader call on the benchmark files is a run; a gathered text would differ in work
            raise ValueError("only runs of numeric text are benchmarked")
        self.text = blob[starts[0] : ends[-1]] if starts.size else b""
        newlines = (
            np.flatnonzero(b[starts[0] : ends[-1]] == 10) + starts[0] if starts.size else np.zeros(0, dtype=np.int64)
        )
        counts = np.diff(
            np.searchsorted(
                starts,
                np.concatenate([[starts[0] if starts.size else 0], newlines + 1, [ends[-1] if starts.size else 0]]),
            )
        )
        self.counts = counts[counts > 0]  # blank lines hold no row (pandas and loadtxt skip them)
        self.size = int(starts.size)


@contextmanager
def recording(bodies: list[Body]):
    """Record every ``_text._parse_tokens`` call made inside the block into ``bodies``."""
    original = _text._parse_tokens

    def record(blob, b, starts, ends, run=False):
        bodies.append(Body(blob, b, starts, ends, run))
        return original(blob, b, starts, ends, run)

    _text._parse_tokens = record
    try:
        yield bodies
    finally:
        _text._parse_tokens = original


def own(body: Body) -> np.ndarray | None:
    return _text._parse_tokens(*body.args)


def with_fromstring(body: Body) -> np.ndarray | None:
    return _text._exactly(_text._parse_row(body.text), body.size)


def with_loadtxt(body: Body) -> np.ndarray | None:
    if body.counts.size and (body.counts != body.counts[0]).any():
        return None  # loadtxt needs one field count for all rows
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            table = np.loadtxt(io.BytesIO(body.text), dtype=np.float64, comments=None, ndmin=2)
    except ValueError:
        return None
    return _text._exactly(table.ravel(), body.size)


def with_pandas(precision: str):
    def convert(body: Body) -> np.ndarray | None:
        import pandas as pd

        width = int(body.counts.max()) if body.counts.size else 0
        try:
            with warnings.catch_warnings():
                warnings.simplefilter(
                    "ignore", DeprecationWarning
                )  # pandas ≥ 3.1: float_precision deprecated (one converter)
                table = pd.read_csv(
                    io.BytesIO(body.text),
                    sep=r"\s+",
                    header=None,
                    names=range(width),
                    dtype=np.float64,
                    engine="c",
                    **({"float_precision": precision} if precision else {}),
                ).to_numpy()
        except (ValueError, pd.errors.ParserError):
            return None
        if table.shape[0] != body.counts.size:
            return None
        if (body.counts == width).all():
            return _text._exactly(table.ravel(), body.size)
        return _text._exactly(table[np.arange(width) < body.counts[:, None]], body.size)

    return convert


#: the conversions compared; "own" is the reader's
CONVERTERS = {
    "own": own,
    "np.fromstring": with_fromstring,
    "np.loadtxt": with_loadtxt,
    "pandas high": with_pandas(None),  # the default: "high" (pandas 3.1: the one converter, fast_float)
    "pandas round_trip": with_pandas("round_trip"),
}


def bit_mismatches(values: np.ndarray | None, expected: np.ndarray) -> int:
    """How many of ``values`` differ in any bit from ``expected`` (all of them if the sizes differ or
    ``values`` is None: the parser failed)."""
    if values is None or values.size != expected.size:
        return expected.size
    a = np.ascontiguousarray(values, dtype=np.float64).view(np.uint64)
    return int(np.count_nonzero(a != np.ascontiguousarray(expected, dtype=np.float64).view(np.uint64)))


def by_float(body: Body) -> np.ndarray:
    """Python's ``float()`` of every token of the body (correctly rounded, as ``strtod``)."""
    return np.array([float(t) for t in body.text.split()], dtype=np.float64)


def _split_only(paths: list[Path]) -> None:
    for p in paths:
        read_bytes(p).decode("latin-1").split("\n")


def cases() -> dict[str, tuple[list[str], list[Path]]]:
    mrclam = [f"utias:6/robot{k}" for k in range(1, 6)]
    return {
        "carmen:intel": (["carmen:intel"], [resolve("carmen:intel").files()["log"]]),
        "utias:6 (5 robots)": (mrclam, [p for n in mrclam for p in resolve(n).files().values()]),
    }


def import_seconds(module: str, repeats: int) -> float:
    """Minimum time to import ``module`` in a fresh interpreter that has already imported numpy."""
    code = f"import time, numpy; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    return min(
        float(subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout)
        for _ in range(repeats)
    )


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def measure(names: list[str], paths: list[Path], repeats: int) -> dict:
    """Minimum times of the reference, the full reader and each conversion; exactness counts."""
    bodies: list[Body] = []
    with recording(bodies):
        for n in names:
            load(n)
    expected = [by_float(body) for body in bodies]
    usable, mismatches = {}, {}
    for (
        key,
        convert,
    ) in CONVERTERS.items():  # also the warm-up: imports (pandas) and first calls stay out of the timings
        values = [convert(body) for body in bodies]
        usable[key] = all(v is not None for v in values)
        mismatches[key] = sum(bit_mismatches(v, e) for v, e in zip(values, expected))
    steps = {"reference": lambda: _split_only(paths), "full": lambda: [load(n) for n in names]}
    for key, convert in CONVERTERS.items():
        steps[key] = lambda convert=convert: [convert(body) for body in bodies]
    best = dict.fromkeys(steps, float("inf"))
    for _ in range(repeats):
        for key, fn in steps.items():
            best[key] = min(best[key], _timed(fn))
    return {"times": best, "usable": usable, "mismatches": mismatches, "numbers": sum(e.size for e in expected)}


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    repeats = 1 if quick else 5
    results = {label: measure(names, paths, repeats) for label, (names, paths) in cases().items()}
    pandas_import = import_seconds("pandas", repeats)
    load_avg = os.getloadavg()[0]
    rows = []
    for label, r in results.items():
        t = r["times"]
        ref = t["reference"]
        rows.append(
            {
                "dataset": label,
                "variant": "decompress + split (reference)",
                "conversion_s": "",
                "reader_s": ref,
                "ratio": 1.0,
                "mismatches": "",
                "numbers": r["numbers"],
                "load_average": load_avg,
            }
        )
        for key in CONVERTERS:
            reader = t["full"] - t["own"] + t[key]
            rows.append(
                {
                    "dataset": label,
                    "variant": "full reader (as shipped)" if key == "own" else f"reader with {key}",
                    "conversion_s": t[key],
                    "reader_s": reader if r["usable"][key] else "",
                    "ratio": reader / ref if r["usable"][key] else "",
                    "mismatches": r["mismatches"][key],
                    "numbers": r["numbers"],
                    "load_average": load_avg,
                }
            )
        reader = t["full"] - t["own"] + t["pandas high"] + pandas_import
        rows.append(
            {
                "dataset": label,
                "variant": "reader with pandas high, + import pandas (first load in a process)",
                "conversion_s": t["pandas high"] + pandas_import,
                "reader_s": reader,
                "ratio": reader / ref,
                "mismatches": "",
                "numbers": r["numbers"],
                "load_average": load_avg,
            }
        )
    ratios = table(
        f"readers vs decompress + line split (same run, min of {repeats}; load average {load_avg:.1f}); "
        "reader with X = full - own conversion + X",
        (
            "dataset",
            "variant",
            "conversion [s]",
            "reader [s]",
            "ratio",
            f"ratio ≤ {AIM_RATIO:g}: verdict",
            "bits != float()",
        ),
    )

    def fmt(x, spec):
        return format(x, spec) if x != "" else "-"

    for row in rows:
        mism = "-" if row["mismatches"] == "" else f"{row['mismatches']} / {row['numbers']}"
        ratios.add_row(
            row["dataset"],
            row["variant"],
            fmt(row["conversion_s"], ".3f"),
            fmt(row["reader_s"], ".3f"),
            fmt(row["ratio"], ".2f"),
            "-" if row["ratio"] == "" else verdict(row["ratio"] <= AIM_RATIO),
            mism,
        )
    Console(width=160).print(ratios)
    write_rows(rows, out, "readers.csv")
    return 0
