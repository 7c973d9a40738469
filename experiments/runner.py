"""The experiment runner: the grid of cells, the cache, parallel execution, summary and tables.

``slamarena run [CONFIG] [--jobs N] [--scheduler ADDRESS] [--out DIR] [--force | --recompute LABEL …] [--dry-run] [--report]``

1. The config is validated (:mod:`slamarena.experiments.config`) before anything runs.
2. The grid datasets × methods × seeds is expanded into cells (a method with a ``datasets:``
   list only on those). A simulator gets the cell's
   seed; a real dataset is the same for every seed, so a method that takes no ``seed`` runs
   once on it (the first seed) instead of repeating an identical computation.
3. Each cell has a cache key: the SHA-256 of the dataset spec (name, parameters, the seed of
   a simulator), the SHA-256 of every file of a real dataset (``slamarena.datasets.catalogue``), the
   method spec, the seed and the slamarena version. A cell whose ``metrics.json`` carries its
   key (and the key of the metric settings) and the SHA-256 of the ``estimate.npz`` and ``series.npz`` still there
   is finished and skipped, so an interrupted run resumes where it stopped (an edited or damaged file is recomputed);
   ``--force`` recomputes every cell, ``--recompute LABEL`` the cells of one method (the key
   does not change with the code, so after a change to a method its cells are recomputed this way).
   The run holds ``<out>/.lock`` (``flock``): a second run into the same directory says which run holds it and
   waits, then skips what that run finished.
4. Pending cells run in processes of their own. Locally, ``--jobs`` threads each feed one long-lived
   worker (:class:`slamarena.experiments.cell.Worker`: it imports the libraries once and forks a child per cell;
   the work, the timeout kill and the memory peak belong to the child); the first cell of each method runs before
   that method's others (:class:`CellQueue`), so its numba kernels are compiled once, into numba's cache, not by
   several cells at once. On a Dask distributed cluster (``--scheduler``) each cell is a fresh process
   (:func:`slamarena.experiments.cell.run_cell`). A failing or timed-out cell does
   not stop the others; its error and traceback go to ``summary.csv`` and the console, and
   the exit code is 1 (a timeout's message says how much of it went to compiling numba kernels). Progress: a bar
   on a terminal, otherwise one line per finished cell with counts and an ETA. Ctrl-C kills the running cells,
   records the interruption in the manifest and says how to resume (exit code 130); a SIGKILL of the runner takes
   its cells with it. A full disk stops the run with one line naming the directory, the space free and about how
   much the cells left need (exit code 1); no temporary file is left, and the same command resumes.
5. ``summary.csv`` (one row per cell), the tables, the Monte Carlo NEES table, the figures
   (drawn by the ``make_figures`` callable the CLI hands in: ``slamarena.paper_figures.make.make_all``)
   and ``manifest.json`` are written (see :mod:`slamarena.experiments.results`); with ``--report``, then
   the report (:mod:`slamarena.experiments.report`); without it, the last line names that next step.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import platform
import shlex
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from rich.markup import escape

from slamarena.errors import UserError

from .cell import CACHED_FILES, DISK_FULL_ERRNOS, file_digest
from .config import ConfigError, ExperimentConfig, load_config
from .results import LOCK, MANIFEST, SUMMARY, atomic_write_text, cell_dir, read_json, write_json

__all__ = ["Cell", "plan", "run_experiment", "run_from_cli", "package_version"]

#: draws the figures of a results directory: ``(out, only=names, verbose=bool) -> (files, errors)``
FigureMaker = Callable[..., tuple[list, dict]]


class SchedulerUnreachable(UserError, RuntimeError):
    """``--scheduler`` names an address where no Dask scheduler answers."""


@dataclass(frozen=True)
class Cell:
    id: str
    dataset: int  # index into config.datasets
    estimator: int  # index into config.estimators
    seed: int
    dir: Path
    key: str
    metrics_key: str
    seed_to_estimator: bool

    def finished(self) -> bool:
        """Whether the cell's ``metrics.json`` says ok for this cell's keys and the files its numbers were computed
        from are still those files (their SHA-256 as recorded): an edited or damaged cached file is recomputed, never
        reused."""
        path = self.dir / "metrics.json"
        if not path.exists():
            return False
        try:
            info = read_json(path)
        except (OSError, json.JSONDecodeError):
            return False
        if not (
            info.get("status") == "ok" and info.get("key") == self.key and info.get("metrics_key") == self.metrics_key
        ):
            return False
        recorded = info.get("files") or {}
        return all(recorded.get(name) and recorded[name] == file_digest(self.dir / name) for name in CACHED_FILES)


def package_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("slamarena")
    except PackageNotFoundError:
        return "unknown"


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def dataset_checksums(name: str, params: dict) -> dict[str, str]:
    """SHA-256 of each file of a real dataset (empty for simulators)."""
    from slamarena.datasets.registry import SIMULATORS, resolve

    if name in SIMULATORS:
        return {}
    return {role: _sha256_file(path) for role, path in resolve(name, params).files().items()}


def plan(config: ExperimentConfig, out: Path) -> list[Cell]:
    """Expand the grid into cells with their directories and cache keys."""
    version = package_version()
    metrics = {k: v.model_dump(mode="json") for k, v in config.enabled_metrics().items()}
    ds_labels, es_labels = config.dataset_labels(), config.estimator_labels()
    seeds = config.seed_list()
    cells = []
    for i, ds in enumerate(config.datasets):
        checksums = dataset_checksums(ds.name, ds.params)
        for j, es in enumerate(config.estimators):
            if es.datasets is not None and ds_labels[i] not in es.datasets:
                continue
            takes_seed = es.takes_seed()
            for seed in seeds if (ds.is_simulator or takes_seed) else seeds[:1]:
                key = _digest(
                    {
                        "dataset": {
                            "name": ds.name,
                            "params": ds.resolved_params(),
                            "seed": seed if ds.is_simulator else None,
                            "files": checksums,
                        },
                        "estimator": {
                            "name": es.name,
                            "params": es.resolved_params(),
                            "seed": seed if takes_seed else None,
                        },
                        "seed": seed,
                        "version": version,
                    }
                )
                cells.append(
                    Cell(
                        id=f"{ds_labels[i]}/{es_labels[j]}/{seed}",
                        dataset=i,
                        estimator=j,
                        seed=seed,
                        dir=cell_dir(out, ds_labels[i], es_labels[j], seed).resolve(),
                        key=key,
                        metrics_key=_digest({"key": key, "metrics": metrics}),
                        seed_to_estimator=takes_seed,
                    )
                )
    return cells


def _spec(config: ExperimentConfig, cell: Cell, env: dict, force: bool = False) -> dict:
    ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
    return {
        "id": cell.id,
        "dir": str(cell.dir),
        "key": cell.key,
        "metrics_key": cell.metrics_key,
        "seed": cell.seed,
        "dataset": {
            "name": ds.name,
            "params": ds.params,
            "label": config.dataset_labels()[cell.dataset],
            "simulator": ds.is_simulator,
        },
        "estimator": {"name": es.name, "params": es.params, "label": config.estimator_labels()[cell.estimator]},
        "seed_to_estimator": cell.seed_to_estimator,
        "metrics": {k: v.model_dump(mode="json") for k, v in config.enabled_metrics().items()},
        "env": env,
        "force": force,
        "mcap": config.mcap,
    }


def _cell_env(config: ExperimentConfig) -> dict:
    """Variables a cell process gets on top of its worker's environment: the data roots in use here, and one
    thread for BLAS, OpenMP and numba if the config asks for single-threaded cells."""
    from slamarena.datasets.dataroot import data_roots

    from .benchmarks import SINGLE_THREAD_ENV

    return {
        "SLAMARENA_DATA": os.pathsep.join(str(p) for p in data_roots()),
        **(SINGLE_THREAD_ENV if config.single_threaded else {}),
    }


# ---------------------------------------------------------------------------- execution
def execute(specs: list[dict], timeout: float | None, jobs: int, scheduler: str | None, on_done) -> list[dict]:
    """Run the pending cells, each in its own process: on ``jobs`` local workers, or on a Dask cluster.

    ``on_done(result)`` is called as each cell ends; a cell that found the disk full stops the run (the cells
    not started yet are left for the next run). On Ctrl-C the cells still running are killed and
    ``KeyboardInterrupt`` propagates to the caller, which records the interruption.
    """
    from .cell import terminate_all

    if not specs:
        return []
    try:
        if scheduler:
            return _execute_dask(specs, timeout, scheduler, on_done)
        return _execute_local(specs, timeout, jobs, on_done)
    except KeyboardInterrupt:
        terminate_all()
        raise


class CellQueue:
    """The pending cells in plan order, handed to the job slots one at a time. The first cell of each method runs
    before that method's other cells: it compiles the method's numba kernels (into numba's on-disk cache) while the
    other slots run other methods, and the method's later cells load them instead of compiling them again at once."""

    def __init__(self, specs: list[dict]):
        self._pending = list(specs)
        self._started: set[str] = set()  # methods whose first cell was handed out
        self._released: set[str] = set()  # methods whose first cell has ended
        self._closed = False
        self._cond = threading.Condition()

    def take(self) -> dict | None:
        """The next cell that may start (waiting while only held-back cells are left); None when none is left."""
        with self._cond:
            while not self._closed and self._pending:
                for i, spec in enumerate(self._pending):
                    method = spec["estimator"]["name"]
                    if method in self._released or method not in self._started:
                        self._started.add(method)
                        return self._pending.pop(i)
                self._cond.wait()
            return None

    def done(self, spec: dict) -> None:
        with self._cond:
            self._released.add(spec["estimator"]["name"])
            self._cond.notify_all()

    def close(self) -> None:
        """Hand out nothing more (the cells running finish)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()


def _execute_local(specs: list[dict], timeout: float | None, jobs: int, on_done) -> list[dict]:
    """``jobs`` threads, each feeding cells from a :class:`CellQueue` to its own
    :class:`~slamarena.experiments.cell.Worker` (a process that has imported everything once and forks a child per
    cell); the main thread reports each result as it comes."""
    import queue

    from .cell import Worker

    cells, ended = CellQueue(specs), queue.Queue()

    def slot() -> None:
        worker = Worker(specs[0].get("env", {}))
        try:
            while (spec := cells.take()) is not None:
                result = worker.run(spec, timeout)
                cells.done(spec)
                ended.put(result)
        finally:
            worker.close()

    threads = [threading.Thread(target=slot, daemon=True) for _ in range(min(jobs, len(specs)))]
    for thread in threads:
        thread.start()
    results = []
    try:
        while any(t.is_alive() for t in threads) or not ended.empty():
            try:
                result = ended.get(timeout=0.2)
            except queue.Empty:
                continue
            results.append(result)
            on_done(result)
            if result["status"] == "disk_full":
                cells.close()
    finally:
        cells.close()
    return results


def _execute_dask(specs: list[dict], timeout: float | None, scheduler: str, on_done) -> list[dict]:
    from distributed import Client, as_completed

    from .cell import run_cell

    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, ValueError, TypeError) as exc:
        raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None
    results = []
    with client:
        futures = client.map(run_cell, specs, [timeout] * len(specs), pure=False)
        try:
            for future in as_completed(futures):
                result = future.result()
                results.append(result)
                on_done(result)
        except KeyboardInterrupt:
            client.cancel(futures)
            raise
    return results


def _git_revision() -> str | None:
    root = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10)
        if rev.returncode != 0:
            return None
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=root,
            capture_output=True,
            text=True,
            timeout=10,
        )
        return rev.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def _versions() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for pkg in (
        "slamarena",
        "numpy",
        "scipy",
        "gtsam",
        "filterpy",
        "open3d-cpu",
        "open3d",
        "kiss-icp",
        "numba",
        "pandas",
        "joblib",
        "distributed",
        "pydantic",
        "matplotlib",
        "evo",
    ):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            continue
    return out


def _machine() -> dict:
    return {
        "hostname": socket.gethostname(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpus": os.cpu_count(),
    }


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


# ---------------------------------------------------------------------------- summary
def collect(config: ExperimentConfig, cells: list[Cell], failures: dict[str, dict]):
    """The summary frame: one row per cell, metric scalars flattened to ``<metric>.<output>``."""
    import pandas as pd

    rows = []
    for cell in cells:
        ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
        row = {
            "dataset": config.dataset_labels()[cell.dataset],
            "estimator": config.estimator_labels()[cell.estimator],
            "seed": cell.seed,
            "dataset_name": ds.name,
            "method": es.name,
        }
        if cell.id in failures:
            row.update(
                status=failures[cell.id]["status"],
                error=failures[cell.id]["error"],
                traceback=failures[cell.id]["traceback"],
            )
        elif cell.finished():
            info = read_json(cell.dir / "metrics.json")
            row.update(status="ok", error="", traceback="")
            for metric, values in info["metrics"].items():
                for key, value in values.items():
                    row[f"{metric}.{key}"] = value
            row["skipped"] = "; ".join(f"{k}: {v}" for k, v in info.get("skipped", {}).items())
        else:
            row.update(status="missing", error="no result (the run was interrupted?)", traceback="")
        rows.append(row)
    return pd.DataFrame(rows)


#: the columns of ``tables/monte_carlo.*`` (:func:`monte_carlo_table`) and what each is
MONTE_CARLO_COLUMNS = {
    "dataset": "dataset label",
    "estimator": "method label",
    "statistic": "nees (pose NEES, 3 degrees of freedom) or nis (the innovations of one stamp summed)",
    "runs": "N, the seeds averaged",
    "stamps": "stamps all N runs share (with equal dimension), where the average is taken",
    "mean_over_dof": "mean over those stamps of the N-run average divided by its degrees of freedom (1 for a consistent filter)",
    "in_band": "fraction of those stamps whose N-run average lies inside the two-sided N-run χ² band",
    "early_over_dof": "the same mean over the first 10 % of the time those stamps span (before any drift)",
    "late_over_dof": "the same mean over the last 10 % of that time (a filter that degrades over the run rises here)",
    "band_lo_over_dof": "the band's lower end divided by the degrees of freedom (mean over the stamps)",
    "band_hi_over_dof": "the band's upper end divided by the degrees of freedom (mean over the stamps)",
}


def monte_carlo_table(config: ExperimentConfig, cells: list[Cell]):
    """Per (dataset, method): NEES and NIS averaged over the seeds at shared stamps, with the
    N-run χ² band (:func:`slamarena.experiments.metrics.consistency.monte_carlo`); one row per statistic."""
    import numpy as np
    import pandas as pd

    from .metrics.consistency import monte_carlo, nis_per_stamp
    from .metrics.reference import MetricUnavailable
    from .metrics.series import Series
    from .results import load_npz

    enabled = config.enabled_metrics()
    groups: dict[tuple[str, str, str], list] = {}
    for cell in cells:
        if not cell.finished() or not (cell.dir / "series.npz").exists():
            continue
        series = load_npz(cell.dir / "series.npz")
        key = (config.dataset_labels()[cell.dataset], config.estimator_labels()[cell.estimator])
        if Series.NEES in series:
            groups.setdefault(key + ("nees",), []).append(
                (series[Series.NEES_T], series[Series.NEES], np.full(series[Series.NEES_T].shape, 3.0))
            )
        if Series.NIS in series:
            groups.setdefault(key + ("nis",), []).append(
                nis_per_stamp(series[Series.NIS_T], series[Series.NIS], series[Series.NIS_DOF])
            )
    rows = []
    for (ds, es, stat), runs in groups.items():
        try:
            mc = monte_carlo(runs, probability=enabled[stat].probability)
        except MetricUnavailable:
            continue
        ratio, t = mc["mean"] / mc["dof"], mc["t"]
        span = t[-1] - t[0]
        rows.append(
            {
                "dataset": ds,
                "estimator": es,
                "statistic": stat,
                "runs": mc["runs"],
                "stamps": int(t.size),
                "mean_over_dof": float(np.mean(ratio)),
                "in_band": mc["in_band"],
                "early_over_dof": float(np.mean(ratio[t <= t[0] + 0.1 * span])),
                "late_over_dof": float(np.mean(ratio[t >= t[-1] - 0.1 * span])),
                "band_lo_over_dof": float(np.mean(mc["lo"] / mc["dof"])),
                "band_hi_over_dof": float(np.mean(mc["hi"] / mc["dof"])),
            }
        )
    return pd.DataFrame(rows)


def _console_summary(console, frame, cells_run: int, cached: int, elapsed: float) -> None:
    """The end-of-run table: one row per (dataset, method), full names even when the console is not a terminal."""
    from rich.table import Table

    table = Table(title=f"{len(frame)} cells: {cells_run} run, {cached} cached, {elapsed:.1f} s", show_lines=False)
    columns = ("dataset", "estimator", "ok/total", "ATE rmse [m]", "RPE trans [m]", "NEES/3", "step median [ms]")
    for col in columns:
        table.add_column(escape(col), justify="right" if col not in ("dataset", "estimator") else "left", no_wrap=True)

    def fmt(group, col, scale=1.0):
        if col not in group or group[col].isna().all():
            return "–"
        values = group[col].dropna() * scale
        return f"{values.mean():.3g}" + (f" ± {values.std():.2g}" if len(values) > 1 else "")

    rows = []
    for (ds, es), group in frame.groupby(["dataset", "estimator"], sort=False):
        ok = int((group["status"] == "ok").sum())
        rows.append(
            (
                (
                    ds,
                    es,
                    f"{ok}/{len(group)}",
                    fmt(group, "ate.rmse"),
                    fmt(group, "rpe.trans_rmse"),
                    fmt(group, "nees.mean_over_dof"),
                    fmt(group, "cost.step_median", 1e3),
                ),
                ok == len(group),
            )
        )
        table.add_row(*(escape(str(v)) for v in rows[-1][0]), style="" if ok == len(group) else "red")
    if not console.is_terminal:  # a log file or CI: as wide as the table needs, never squeezed names
        widths = [max([len(c)] + [len(str(r[0][k])) for r in rows]) for k, c in enumerate(columns)]
        console.width = max(console.width, sum(widths) + 3 * len(widths) + 4)
    console.print(table)
    failed = frame[frame["status"] != "ok"]
    for _, row in failed.head(8).iterrows():
        console.print(
            f"[red]✗ {escape(str(row['dataset']))}/{escape(str(row['estimator']))}/{row['seed']}[/red] "
            f"{escape(str(row['status']))}: {escape(str(row['error']))}"
        )
    if len(failed) > 8:
        console.print(f"[red]… and {len(failed) - 8} more failed cells (see summary.csv)[/red]")


# ---------------------------------------------------------------------------- the steps of a run
def start_manifest(
    config: ExperimentConfig, out: Path, cells: list[Cell], pending: list[Cell], jobs: int, scheduler: str | None
) -> dict:
    """Write ``manifest.json`` as the run starts (``finished`` stays null until it ends)."""
    manifest = {
        "experiment": config.name,
        "config": config.model_dump(mode="json"),
        "resolved_params": {
            "datasets": {lbl: ds.resolved_params() for lbl, ds in zip(config.dataset_labels(), config.datasets)},
            "estimators": {lbl: es.resolved_params() for lbl, es in zip(config.estimator_labels(), config.estimators)},
        },
        "versions": _versions(),
        "git_revision": _git_revision(),
        "machine": _machine(),
        "command": sys.argv,
        "scheduler": scheduler,
        "jobs": jobs,
        "started": _now(),
        "finished": None,
        "interrupted": None,
        "cells": {"total": len(cells), "to_run": len(pending), "cached": len(cells) - len(pending)},
    }
    write_json(out / MANIFEST, manifest)
    return manifest


def forced_cells(config: ExperimentConfig, cells: list[Cell], force: bool, recompute: frozenset[str]) -> set[str]:
    """Ids of the cells recomputed even if cached: all with ``force``, else those of the methods labelled in ``recompute``."""
    labels = config.estimator_labels()
    return {c.id for c in cells if force or labels[c.estimator] in recompute}


def check_recompute(config: ExperimentConfig, recompute: frozenset[str]) -> None:
    """Refuse a ``--recompute`` label that names no method of the config (UsageError, the known labels listed)."""
    unknown = sorted(set(recompute) - set(config.estimator_labels()))
    if unknown:
        raise UsageError(
            f"--recompute {', '.join(unknown)}: no such method label in {config.name}; "
            f"its labels: {', '.join(config.estimator_labels())}"
        )


def run_cells(
    config: ExperimentConfig, pending: list[Cell], jobs: int, scheduler: str | None, forced: set[str], console
) -> dict[str, dict]:
    """Execute the pending cells (those in ``forced`` recomputed even if cached); returns their results by id (a cell
    not started, after a full disk stopped the run, has none).

    On a terminal, a progress bar; otherwise (stderr to a file: nohup, tee, CI) one line per finished cell with the
    counts done/total and failed, the elapsed time and an ETA (:class:`ProgressLines`)."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    env = _cell_env(config)
    ended: dict[str, dict] = {}
    if console.is_terminal:
        progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("elapsed"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=console,
            transient=False,
        )
    else:
        progress = ProgressLines(console)
    with progress:
        task = progress.add_task(escape(config.name), total=len(pending))

        def on_done(result):
            ended[result["id"]] = result
            if isinstance(progress, ProgressLines):
                progress.finished(result, sum(r["status"] != "ok" for r in ended.values()))
            else:
                progress.advance(task)

        execute([_spec(config, c, env, c.id in forced) for c in pending], config.timeout, jobs, scheduler, on_done)
    return ended


class ProgressLines:
    """Progress without a terminal: ``[12/70] sim_landmarks/ekf_slam/3 ok 4.2 s · 0 failed · 1:02 elapsed, ETA 4:10``,
    one line per finished cell (the ETA: the mean time per finished cell so far times the cells left)."""

    def __init__(self, console):
        self.console = console
        self.total = 0
        self.done = 0
        self.start = time.perf_counter()

    def __enter__(self) -> ProgressLines:
        return self

    def __exit__(self, *exc) -> None:
        return None

    def add_task(self, description: str, total: int) -> int:
        self.total = total
        self.console.print(f"{description}: {total} cells to run", highlight=False)
        return 0

    def finished(self, result: dict, failed: int) -> None:
        self.done += 1
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        status = result["status"] + ("" if result["status"] == "ok" else f" ({result['error']})")
        self.console.print(
            escape(
                f"[{self.done}/{self.total}] {result['id']} {status} {result['elapsed']:.1f} s · {failed} failed · "
                f"{_clock(elapsed)} elapsed, ETA {_clock(eta)}"
            ),
            highlight=False,
            soft_wrap=True,
        )


def _clock(seconds: float) -> str:
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes}:{secs:02d}" if minutes < 60 else f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


def write_outputs(config: ExperimentConfig, cells: list[Cell], frame, out: Path) -> list[Path]:
    """``summary.csv``, the configured tables (or the default one) and the Monte Carlo table."""
    from .tables import table_specs, write_frame, write_tables

    atomic_write_text(out / SUMMARY, frame.to_csv(index=False))
    written = write_tables(
        frame, table_specs(config.tables, config.enabled_metrics()), out / "tables", config.published
    )
    mc_frame = monte_carlo_table(config, cells)
    if len(mc_frame):
        written += write_frame(mc_frame, out / "tables" / "monte_carlo")
    return written


def draw_figures(config: ExperimentConfig, out: Path, make_figures: FigureMaker | None) -> tuple[list, dict]:
    """The config's figures, drawn by the injected ``make_figures`` (none without one)."""
    if make_figures is None or not config.figures:
        return [], {}
    return make_figures(out, only=config.figures, verbose=False)


def record_interruption(manifest: dict, out: Path, cells: list[Cell], console) -> None:
    """After Ctrl-C: the manifest says so, and the console says what finished and how to resume."""
    done = sum(c.finished() for c in cells)
    manifest["interrupted"] = {"at": _now(), "finished_cells": done, "total_cells": len(cells)}
    write_json(out / MANIFEST, manifest)
    command = " ".join(shlex.quote(a) for a in (manifest["command"] or ["slamarena", "run"]))
    console.print(
        f"[yellow]interrupted: {done} of {len(cells)} cells are finished and kept in {escape(str(out))}.[/yellow]"
    )
    console.print(f"resume with the same command (finished cells are skipped): {escape(command)}", highlight=False)


def run_experiment(
    config: ExperimentConfig,
    out: Path,
    jobs: int = 1,
    scheduler: str | None = None,
    force: bool = False,
    console=None,
    make_figures: FigureMaker | None = None,
    report: bool = False,
    recompute: frozenset[str] = frozenset(),
) -> int:
    """Run (or resume) an experiment into ``out``: plan → run the cells → collect → tables → figures (→ report).

    Returns the exit code: 0 every cell ok, 1 some cell failed or timed out, 130 interrupted (Ctrl-C); raises
    :class:`DiskFull` (one line: the directory, the space free and needed) when the disk is full.
    ``make_figures(out, only=names, verbose=False) -> (files, errors)`` draws the config's figures; the
    CLI passes :func:`slamarena.paper_figures.make.make_all` (figures are the layer above this one, so
    they are handed in rather than imported). ``report`` writes ``report.html`` and ``report.md`` at the end
    (:mod:`slamarena.experiments.report`). ``force`` recomputes every cell, ``recompute`` the cells of the methods with
    these labels (:func:`check_recompute`).
    """
    from rich.console import Console

    check_recompute(config, recompute)
    console = console or Console(stderr=True)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    try:
        with results_lock(out, console):
            return _run_locked(config, out, jobs, scheduler, force, console, make_figures, report, recompute, t_start)
    except KeyboardInterrupt:  # while waiting for the lock: nothing ran
        console.print("[yellow]interrupted before any cell ran[/yellow]")
        return 130
    except OSError as exc:  # no space even for the lock file's line (a full disk inside a run is handled there)
        if exc.errno not in DISK_FULL_ERRNOS:
            raise
        cells = plan(config, out)
        raise DiskFull(disk_full_message(out, cells, sum(not c.finished() for c in cells))) from None


def _run_locked(
    config: ExperimentConfig,
    out: Path,
    jobs: int,
    scheduler: str | None,
    force: bool,
    console,
    make_figures: FigureMaker | None,
    report: bool,
    recompute: frozenset[str],
    t_start: float,
) -> int:
    """:func:`run_experiment` once ``out`` is locked: which cells are finished is read only now (another run may have
    finished some while this one waited)."""
    cells = plan(config, out)
    forced = forced_cells(config, cells, force, recompute)
    pending = [c for c in cells if c.id in forced or not c.finished()]
    left = len(pending)
    try:
        manifest = start_manifest(config, out, cells, pending, jobs, scheduler)
        try:
            ended = run_cells(config, pending, jobs, scheduler, forced, console)
        except KeyboardInterrupt:
            record_interruption(manifest, out, cells, console)
            return 130
        failures = {i: r for i, r in ended.items() if r["status"] != "ok"}
        left = len(pending) - (len(ended) - len(failures))
        if any(f["status"] == "disk_full" for f in failures.values()):
            raise OSError(errno.ENOSPC, "no space left on device")
        frame = collect(config, cells, failures)
        tables = write_outputs(config, cells, frame, out)
        figure_files, figure_errors = draw_figures(config, out, make_figures)
        elapsed = time.perf_counter() - t_start
        manifest.update(
            finished=_now(),
            duration_s=elapsed,
            failed=sorted(failures),
            tables=[str(p.relative_to(out)) for p in tables],
            figures=[str(Path(p).relative_to(out)) for p in figure_files],
            figure_errors=figure_errors,
        )
        write_json(out / MANIFEST, manifest)
    except OSError as exc:
        if exc.errno not in DISK_FULL_ERRNOS:
            raise
        raise DiskFull(disk_full_message(out, cells, left)) from None
    _console_summary(console, frame, len(pending), len(cells) - len(pending), elapsed)
    for name, err in figure_errors.items():
        console.print(f"[yellow]figure {escape(name)} not drawn: {escape(str(err))}[/yellow]")
    console.print(f"results: {escape(str(out))}", highlight=False)
    if report:
        from .report import write_report

        html, _ = write_report(out)
        console.print(f"report: {escape(str(html))} (open it in a browser)", highlight=False)
    else:
        console.print(
            f"next: slamarena report {escape(shlex.quote(str(out)))}  (every table and figure on one page, report.html)",
            highlight=False,
        )
    return 0 if (frame["status"] == "ok").all() else 1


class DiskFull(UserError, OSError):
    """The disk holding the results directory is full (the message names it and the space the run still needs)."""


def disk_full_message(out: Path, cells: list[Cell], left: int) -> str:
    """One line: where, how much is free, and about how much the ``left`` cells not finished by this run need (the
    mean size of the directories of the cells with a ``metrics.json`` times that count)."""
    import shutil

    def mb(n: float) -> str:
        return f"{n / 2**20:.0f} MB" if n >= 2**20 else f"{n / 2**10:.0f} kB"

    finished = [c for c in cells if (c.dir / "metrics.json").is_file()]
    sizes = [sum(f.stat().st_size for f in c.dir.iterdir() if f.is_file()) for c in finished]
    free = shutil.disk_usage(out).free
    if sizes and left:
        per = sum(sizes) / len(sizes)
        need = f"the {left} cells left need about {mb(per * left)} ({mb(per)} each) plus the tables and figures"
    elif not left:
        need = "every cell is finished; the tables and figures need a few MB"
    else:
        need = f"no cell finished to measure a cell's size ({left} cells left)"
    return (
        f"disk full: no space left writing to {out} ({mb(free)} free; {need}); "
        f"free some space and run the same command again (finished cells are kept)"
    )


@contextmanager
def results_lock(out: Path, console):
    """Hold ``out/.lock`` (``flock``, released by the kernel if this process dies) while a run writes into ``out``. A
    second run into the same directory says which run holds it (pid, host, since when) and waits for it; then it
    skips the cells that run finished."""
    import fcntl

    with open(out / LOCK, "a+") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "another run"
            console.print(
                f"[yellow]{escape(str(out))} is in use by {escape(holder)}; waiting for it to end "
                f"(Ctrl-C to stop)[/yellow]",
                highlight=False,
            )
            fcntl.flock(fh, fcntl.LOCK_EX)
        fh.seek(0)
        fh.truncate()
        fh.write(f"slamarena run pid {os.getpid()} on {socket.gethostname()} since {_now()}\n")
        fh.flush()
        yield


def print_grid(
    config: ExperimentConfig, out: Path, force: bool, console, recompute: frozenset[str] = frozenset()
) -> int:
    """``--dry-run``: the resolved parameters of every dataset and method, and the grid of cells with the cached ones."""
    from rich.table import Table

    params = Table(title=f"{escape(config.name)}: resolved parameters (defaults filled in)", show_lines=True)
    for col in ("", "label", "name", "parameters"):
        params.add_column(col, overflow="fold")
    for kind, labels, specs in (
        ("dataset", config.dataset_labels(), config.datasets),
        ("method", config.estimator_labels(), config.estimators),
    ):
        for label, spec in zip(labels, specs):
            resolved = spec.resolved_params()
            params.add_row(
                kind,
                escape(label),
                escape(spec.name),
                escape(", ".join(f"{k}={json.dumps(v)}" for k, v in resolved.items()) or "–"),
            )
    console.print(params)
    cells = plan(config, out)
    forced = forced_cells(config, cells, force, recompute)
    table = Table(title=f"{escape(config.name)}: {len(cells)} cells → {escape(str(out))}")
    for col in ("dataset", "method", "seed", "status", "directory"):
        table.add_column(col)
    for cell in cells:
        state = "cached" if (cell.finished() and cell.id not in forced) else "to run"
        table.add_row(
            escape(config.dataset_labels()[cell.dataset]),
            escape(config.estimator_labels()[cell.estimator]),
            str(cell.seed),
            state,
            escape(str(cell.dir.relative_to(Path(out).resolve()))),
        )
    console.print(table)
    return 0


class UsageError(UserError, ValueError):
    """A command-line value that cannot work (the message says which and why)."""


def check_run_options(jobs: int, scheduler: str | None, out: Path) -> None:
    """Refuse, before anything runs: ``--jobs`` below 1, a ``--scheduler`` that is not an address, an ``--out``
    that is (or lies under) a file or cannot be created."""
    if jobs < 1:
        raise UsageError(f"--jobs must be at least 1, got {jobs}")
    if scheduler is not None:
        from urllib.parse import urlsplit

        parts = urlsplit(scheduler if "://" in scheduler else f"tcp://{scheduler}")
        try:
            port = parts.port
        except ValueError:
            port = None
        if not parts.hostname or port is None:
            raise UsageError(f"--scheduler must be a Dask scheduler address such as tcp://host:8786, got {scheduler!r}")
    for parent in (out, *out.parents):
        if parent.exists():
            if not parent.is_dir():
                raise UsageError(f"--out {out}: {parent} is a file, not a directory")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise UsageError(f"--out {out}: {parent} is not writable")
            break


def run_from_cli(
    config: Path | None,
    jobs: int,
    scheduler: str | None,
    out: Path | None,
    force: bool,
    dry_run: bool,
    make_figures: FigureMaker | None = None,
    report: bool = False,
    seeds: int | None = None,
    recompute: tuple[str, ...] = (),
) -> int:
    """``slamarena run``: validate, then run (or list) the grid; ``seeds`` replaces the config's seeds by 0 … seeds − 1.

    Exit codes: 0 every cell ok, 1 some cell failed or timed out or the disk is full, 2 invalid config, option or unreachable
    scheduler, 130 interrupted.
    """
    from rich.console import Console

    console = Console(stderr=True)
    try:
        cfg = load_config(config)
        if seeds is not None:
            cfg = cfg.model_copy(update={"seeds": seeds})
        target = cfg.output_dir(out)
        check_run_options(jobs, scheduler, target)
        recompute = frozenset(recompute)
        check_recompute(cfg, recompute)
    except (ConfigError, UsageError) as exc:
        console.print(f"[red]{escape(str(exc))}[/red]", highlight=False)
        return 2
    if dry_run:
        return print_grid(cfg, target, force, Console(), recompute)
    try:
        return run_experiment(
            cfg,
            target,
            jobs=jobs,
            scheduler=scheduler,
            force=force,
            console=console,
            make_figures=make_figures,
            report=report,
            recompute=recompute,
        )
    except SchedulerUnreachable as exc:
        console.print(f"[red]{escape(str(exc))}[/red]", highlight=False)
        return 2
    except DiskFull as exc:
        console.print(f"[red]{escape(str(exc))}[/red]", highlight=False, soft_wrap=True)
        return 1
