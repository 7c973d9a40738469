"""The experiment runner: the grid of cells, the cache, parallel execution, summary and tables.

``slamarena run [CONFIG] [--jobs N] [--scheduler ADDRESS] [--out DIR] [--force] [--dry-run]``

1. The config is validated (:mod:`slamarena.experiments.config`) before anything runs.
2. The grid datasets × methods × seeds is expanded into cells (a method with a ``datasets:``
   list only on those). A simulator gets the cell's
   seed; a real dataset is the same for every seed, so a method that takes no ``seed`` runs
   once on it (the first seed) instead of repeating an identical computation.
3. Each cell has a cache key: the SHA-256 of the dataset spec (name, parameters, the seed of
   a simulator), the SHA-256 of every file of a real dataset (``slamarena.datasets.catalogue``), the
   method spec, the seed and the slamarena version. A cell whose ``metrics.json`` carries its
   key (and the key of the metric settings) is finished and skipped, so an interrupted run
   resumes where it stopped; ``--force`` recomputes.
4. Pending cells run in their own processes (:func:`slamarena.experiments.cell.run_cell`): locally on
   ``--jobs`` joblib worker threads, each supervising one cell process (the threads only
   wait; the work, the timeout kill and the memory peak belong to the cell's own process),
   or on a Dask distributed cluster with ``--scheduler``. A failing or timed-out cell does
   not stop the others; its error and traceback go to ``summary.csv`` and the console, and
   the exit code is 1.
5. ``summary.csv`` (one row per cell), the tables, the Monte Carlo NEES table, the figures
   (drawn by the ``make_figures`` callable the CLI hands in: ``slamarena.paper_figures.make.make_all``)
   and ``manifest.json`` are written (see :mod:`slamarena.experiments.results`).
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from .config import ConfigError, ExperimentConfig, load_config
from .results import MANIFEST, SUMMARY, atomic_write_text, cell_dir, read_json, write_json

__all__ = ["Cell", "plan", "run_experiment", "run_from_cli", "package_version"]

#: draws the figures of a results directory: ``(out, only=names, verbose=bool) -> (files, errors)``
FigureMaker = Callable[..., tuple[list, dict]]


class SchedulerUnreachable(RuntimeError):
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
        path = self.dir / "metrics.json"
        if not path.exists():
            return False
        try:
            info = read_json(path)
        except (OSError, json.JSONDecodeError):
            return False
        return info.get("status") == "ok" and info.get("key") == self.key and info.get("metrics_key") == self.metrics_key


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


def dataset_checksums(name: str) -> dict[str, str]:
    """SHA-256 of each file of a real dataset (empty for simulators)."""
    from slamarena.datasets.catalogue import CATALOGUE

    if name not in CATALOGUE:
        return {}
    return {role: _sha256_file(path) for role, path in CATALOGUE[name].paths().items()}


def plan(config: ExperimentConfig, out: Path) -> list[Cell]:
    """Expand the grid into cells with their directories and cache keys."""
    version = package_version()
    metrics = {k: v.model_dump(mode="json") for k, v in config.enabled_metrics().items()}
    ds_labels, es_labels = config.dataset_labels(), config.estimator_labels()
    seeds = config.seed_list()
    cells = []
    for i, ds in enumerate(config.datasets):
        checksums = dataset_checksums(ds.name)
        for j, es in enumerate(config.estimators):
            if es.datasets is not None and ds_labels[i] not in es.datasets:
                continue
            takes_seed = es.takes_seed()
            for seed in seeds if (ds.is_simulator or takes_seed) else seeds[:1]:
                key = _digest({
                    "dataset": {"name": ds.name, "params": ds.resolved_params(), "seed": seed if ds.is_simulator else None, "files": checksums},
                    "estimator": {"name": es.name, "params": es.resolved_params(), "seed": seed if takes_seed else None},
                    "seed": seed,
                    "version": version,
                })
                cells.append(Cell(
                    id=f"{ds_labels[i]}/{es_labels[j]}/{seed}", dataset=i, estimator=j, seed=seed,
                    dir=cell_dir(out, ds_labels[i], es_labels[j], seed).resolve(),
                    key=key, metrics_key=_digest({"key": key, "metrics": metrics}), seed_to_estimator=takes_seed,
                ))
    return cells


def _spec(config: ExperimentConfig, cell: Cell, env: dict, force: bool = False) -> dict:
    ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
    return {
        "id": cell.id, "dir": str(cell.dir), "key": cell.key, "metrics_key": cell.metrics_key, "seed": cell.seed,
        "dataset": {"name": ds.name, "params": ds.params, "label": config.dataset_labels()[cell.dataset], "simulator": ds.is_simulator},
        "estimator": {"name": es.name, "params": es.params, "label": config.estimator_labels()[cell.estimator]},
        "seed_to_estimator": cell.seed_to_estimator,
        "metrics": {k: v.model_dump(mode="json") for k, v in config.enabled_metrics().items()},
        "env": env,
        "force": force,
    }


def _cell_env() -> dict:
    """Variables a cell process gets on top of its worker's environment: the data roots in use here."""
    from slamarena.datasets.dataroot import data_roots

    return {"SLAMARENA_DATA": os.pathsep.join(str(p) for p in data_roots())}


# ---------------------------------------------------------------------------- execution
def _execute(specs: list[dict], timeout: float | None, jobs: int, scheduler: str | None, on_done) -> list[dict]:
    from .cell import run_cell

    results = []
    if not specs:
        return results
    if scheduler:
        from distributed import Client, as_completed

        try:
            client = Client(scheduler, timeout="20s")
        except OSError as exc:
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        with client:
            futures = client.map(run_cell, specs, [timeout] * len(specs), pure=False)
            for future in as_completed(futures):
                result = future.result()
                results.append(result)
                on_done(result)
        return results
    from joblib import Parallel, delayed

    parallel = Parallel(n_jobs=max(1, jobs), backend="threading", return_as="generator_unordered")
    for result in parallel(delayed(run_cell)(spec, timeout) for spec in specs):
        results.append(result)
        on_done(result)
    return results


def _git_revision() -> str | None:
    root = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10)
        if rev.returncode != 0:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root, capture_output=True, text=True, timeout=10)
        return rev.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        return None


def _versions() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for pkg in ("slamarena", "numpy", "scipy", "gtsam", "filterpy", "open3d-cpu", "open3d", "kiss-icp", "numba", "pandas", "joblib", "distributed", "pydantic", "matplotlib", "evo"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            continue
    return out


def _machine() -> dict:
    return {"hostname": socket.gethostname(), "platform": platform.platform(), "processor": platform.processor() or platform.machine(), "cpus": os.cpu_count()}


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


# ---------------------------------------------------------------------------- summary
def collect(config: ExperimentConfig, cells: list[Cell], failures: dict[str, dict]):
    """The summary frame: one row per cell, metric scalars flattened to ``<metric>.<output>``."""
    import pandas as pd

    rows = []
    for cell in cells:
        ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
        row = {"dataset": config.dataset_labels()[cell.dataset], "estimator": config.estimator_labels()[cell.estimator], "seed": cell.seed, "dataset_name": ds.name, "method": es.name}
        if cell.id in failures:
            row.update(status=failures[cell.id]["status"], error=failures[cell.id]["error"], traceback=failures[cell.id]["traceback"])
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


def monte_carlo_table(config: ExperimentConfig, cells: list[Cell]):
    """Per (dataset, method): NEES and NIS averaged over the seeds at shared stamps, with the
    N-run χ² band (:func:`slamarena.experiments.metrics.consistency.monte_carlo`); one row per statistic."""
    import numpy as np
    import pandas as pd

    from .metrics.consistency import monte_carlo, nis_per_stamp
    from .metrics.reference import MetricUnavailable
    from .results import load_npz

    enabled = config.enabled_metrics()
    groups: dict[tuple[str, str, str], list] = {}
    for cell in cells:
        if not cell.finished() or not (cell.dir / "series.npz").exists():
            continue
        series = load_npz(cell.dir / "series.npz")
        key = (config.dataset_labels()[cell.dataset], config.estimator_labels()[cell.estimator])
        if "nees/nees" in series:
            groups.setdefault(key + ("nees",), []).append((series["nees/t"], series["nees/nees"], np.full(series["nees/t"].shape, 3.0)))
        if "nis/nis" in series:
            groups.setdefault(key + ("nis",), []).append(nis_per_stamp(series["nis/t"], series["nis/nis"], series["nis/dof"]))
    rows = []
    for (ds, es, stat), runs in groups.items():
        try:
            mc = monte_carlo(runs, probability=enabled[stat].probability)
        except MetricUnavailable:
            continue
        rows.append({"dataset": ds, "estimator": es, "statistic": stat, "runs": mc["runs"], "stamps": int(mc["t"].size),
                     "mean_over_dof": float(np.mean(mc["mean"] / mc["dof"])), "in_band": mc["in_band"]})
    return pd.DataFrame(rows)


def _console_summary(console, frame, cells_run: int, cached: int, elapsed: float) -> None:
    from rich.table import Table

    table = Table(title=f"{len(frame)} cells: {cells_run} run, {cached} cached, {elapsed:.1f} s", show_lines=False)
    for col in ("dataset", "estimator", "ok/total", "ATE rmse [m]", "RPE trans [m]", "NEES/3", "step median [ms]"):
        table.add_column(col, justify="right" if col not in ("dataset", "estimator") else "left")

    def fmt(group, col, scale=1.0):
        if col not in group or group[col].isna().all():
            return "–"
        values = group[col].dropna() * scale
        return f"{values.mean():.3g}" + (f" ± {values.std():.2g}" if len(values) > 1 else "")

    for (ds, es), group in frame.groupby(["dataset", "estimator"], sort=False):
        ok = int((group["status"] == "ok").sum())
        style = "" if ok == len(group) else "red"
        table.add_row(ds, es, f"{ok}/{len(group)}", fmt(group, "ate.rmse"), fmt(group, "rpe.trans_rmse"), fmt(group, "nees.mean_over_dof"), fmt(group, "cost.step_median", 1e3), style=style)
    console.print(table)
    failed = frame[frame["status"] != "ok"]
    for _, row in failed.head(8).iterrows():
        console.print(f"[red]✗ {row['dataset']}/{row['estimator']}/{row['seed']}[/red] {row['status']}: {row['error']}")
    if len(failed) > 8:
        console.print(f"[red]… and {len(failed) - 8} more failed cells (see summary.csv)[/red]")


# ---------------------------------------------------------------------------- entry points
def run_experiment(config: ExperimentConfig, out: Path, jobs: int = 1, scheduler: str | None = None, force: bool = False, console=None, make_figures: FigureMaker | None = None) -> int:
    """Run (or resume) an experiment into ``out``; returns the exit code (0: every cell ok).

    ``make_figures(out, only=names, verbose=False) -> (files, errors)`` draws the config's
    figures at the end; the CLI passes :func:`slamarena.paper_figures.make.make_all` (figures are the
    layer above this one, so they are handed in rather than imported).
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from .tables import default_columns, write_tables

    console = console or Console(stderr=True)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started, t_start = _now(), time.perf_counter()
    cells = plan(config, out)
    pending = [c for c in cells if force or not c.finished()]
    manifest = {
        "experiment": config.name,
        "config": config.model_dump(mode="json"),
        "versions": _versions(),
        "git_revision": _git_revision(),
        "machine": _machine(),
        "command": sys.argv,
        "scheduler": scheduler,
        "jobs": jobs,
        "started": started,
        "finished": None,
        "cells": {"total": len(cells), "to_run": len(pending), "cached": len(cells) - len(pending)},
    }
    write_json(out / MANIFEST, manifest)
    env = _cell_env()
    failures: dict[str, dict] = {}
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("elapsed"), TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), console=console, transient=False) as progress:
        task = progress.add_task(config.name, total=len(pending))

        def on_done(result):
            if result["status"] != "ok":
                failures[result["id"]] = result
            progress.advance(task)

        _execute([_spec(config, c, env, force) for c in pending], config.timeout, jobs, scheduler, on_done)

    frame = collect(config, cells, failures)
    atomic_write_text(out / SUMMARY, frame.to_csv(index=False))
    tables = config.tables or [{"name": "summary", "columns": default_columns(config.enabled_metrics())}]
    written = write_tables(frame, tables, out / "tables")
    mc_frame = monte_carlo_table(config, cells)
    if len(mc_frame):
        from .tables import write_frame

        written += write_frame(mc_frame, out / "tables" / "monte_carlo")
    figure_files, figure_errors = [], {}
    if make_figures is not None and config.figures:
        figure_files, figure_errors = make_figures(out, only=config.figures, verbose=False)
    elapsed = time.perf_counter() - t_start
    manifest.update(finished=_now(), duration_s=elapsed, failed=sorted(failures), tables=[str(p.relative_to(out)) for p in written], figures=[str(Path(p).relative_to(out)) for p in figure_files], figure_errors=figure_errors)
    write_json(out / MANIFEST, manifest)
    _console_summary(console, frame, len(pending), len(cells) - len(pending), elapsed)
    for name, err in figure_errors.items():
        console.print(f"[yellow]figure {name} not drawn: {err}[/yellow]")
    console.print(f"results: {out}")
    return 0 if (frame["status"] == "ok").all() else 1


def print_grid(config: ExperimentConfig, out: Path, force: bool, console) -> int:
    """``--dry-run``: the grid of cells, with the ones already cached."""
    from rich.table import Table

    cells = plan(config, out)
    table = Table(title=f"{config.name}: {len(cells)} cells → {out}")
    for col in ("dataset", "method", "seed", "status", "directory"):
        table.add_column(col)
    for cell in cells:
        state = "cached" if (cell.finished() and not force) else "to run"
        table.add_row(config.dataset_labels()[cell.dataset], config.estimator_labels()[cell.estimator], str(cell.seed), state, str(cell.dir.relative_to(Path(out).resolve())))
    console.print(table)
    return 0


def run_from_cli(config: Path | None, jobs: int, scheduler: str | None, out: Path | None, force: bool, dry_run: bool, make_figures: FigureMaker | None = None) -> int:
    """``slamarena run``: validate, then run (or list) the grid.

    Exit codes: 0 every cell ok, 1 some cell failed or timed out, 2 invalid config or unreachable scheduler.
    """
    from rich.console import Console

    console = Console(stderr=True)
    try:
        cfg = load_config(config)
    except ConfigError as exc:
        console.print(f"[red]{exc}[/red]", highlight=False)
        return 2
    target = cfg.output_dir(out)
    if dry_run:
        return print_grid(cfg, target, force, Console())
    try:
        return run_experiment(cfg, target, jobs=jobs, scheduler=scheduler, force=force, console=console, make_figures=make_figures)
    except SchedulerUnreachable as exc:
        console.print(f"[red]{exc}[/red]", highlight=False)
        return 2
