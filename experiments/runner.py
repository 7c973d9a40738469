"""The experiment runner: :func:`run_experiment` drives a run through its steps, each in a module of its own —
the plan and cache keys (:mod:`~slamarena.experiments.plan`), running the cells (:mod:`~slamarena.experiments.execute`,
:mod:`~slamarena.experiments.cell`), the manifest (:mod:`~slamarena.experiments.manifest`), the summary and tables
(:mod:`~slamarena.experiments.tables`), what is printed (:mod:`~slamarena.experiments.console`), the lock and a full
disk (:mod:`~slamarena.experiments.outdir`); the command line is :mod:`~slamarena.experiments.cli_run`.

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
6. The config's ``claims:`` are checked on the run (:mod:`slamarena.experiments.claims`): one that does not hold is
   listed with its value and bound, and the exit code is 1, as for a failed cell.
"""

from __future__ import annotations

import errno
import time
from collections.abc import Callable
from pathlib import Path

from rich.markup import escape

from .cell import DISK_FULL_ERRNOS
from .cellspec import CellOutcome
from .config import ExperimentConfig
from .console import ProgressLines, console_summary, print_next_step, print_results, progress
from .execute import execute
from .manifest import finish_manifest, record_interruption, start_manifest
from .outdir import DiskFull, disk_full_message, results_lock
from .plan import Cell, cell_env, cell_spec, check_recompute, forced_cells, plan
from .protocol import write_protocol
from .results import SUMMARY, atomic_write_text
from .tables import collect, monte_carlo_table, table_specs, write_frame, write_tables

__all__ = ["run_experiment", "run_cells", "write_outputs", "draw_figures", "FigureMaker"]

#: draws the figures of a results directory: ``(out, only=names, verbose=bool) -> (files, errors)``
FigureMaker = Callable[..., tuple[list, dict]]


def run_cells(
    config: ExperimentConfig, pending: list[Cell], jobs: int, scheduler: str | None, forced: set[str], console
) -> dict[str, CellOutcome]:
    """Execute the pending cells (those in ``forced`` recomputed even if cached); returns their outcomes by id (a cell
    not started, after a full disk stopped the run, has none).

    On a terminal, a progress bar; otherwise (stderr to a file: nohup, tee, CI) one line per finished cell with the
    counts done/total and failed, the elapsed time and an ETA (:class:`~slamarena.experiments.console.ProgressLines`)."""
    env = cell_env(config)
    ended: dict[str, CellOutcome] = {}
    with progress(console) as bar:
        task = bar.add_task(escape(config.name), total=len(pending))

        def on_done(result: CellOutcome) -> None:
            ended[result.id] = result
            if isinstance(bar, ProgressLines):
                bar.finished(result, sum(not r.ok for r in ended.values()))
            else:
                bar.advance(task)

        execute([cell_spec(config, c, env, c.id in forced) for c in pending], config.timeout, jobs, scheduler, on_done)
    return ended


def write_outputs(config: ExperimentConfig, cells: list[Cell], frame, out: Path) -> list[Path]:
    """``summary.csv``, the configured tables (or the default one), the Monte Carlo table and, for a config with a
    protocol, its held-out table (:mod:`~slamarena.experiments.protocol`)."""
    atomic_write_text(out / SUMMARY, frame.to_csv(index=False))
    written = write_tables(
        frame, table_specs(config.tables, config.enabled_metrics()), out / "tables", config.published
    )
    mc_frame = monte_carlo_table(config, cells)
    if len(mc_frame):
        written += write_frame(mc_frame, out / "tables" / "monte_carlo")
    if config.protocol is not None:
        written += write_protocol(frame, config, out)
    return written


def write_report_html(out: Path) -> Path:
    """``report.html`` and ``report.md`` of ``out`` (:mod:`slamarena.experiments.report`); returns the HTML's path."""
    from .report import write_report

    html, _ = write_report(out)
    return html


def draw_figures(config: ExperimentConfig, out: Path, make_figures: FigureMaker | None) -> tuple[list, dict]:
    """The config's figures, drawn by the injected ``make_figures`` (none without one)."""
    if make_figures is None or not config.figures:
        return [], {}
    return make_figures(out, only=config.figures, verbose=False)


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

    Returns the exit code: 0 every cell ok and every claim of the config holds, 1 some cell failed or timed out or a
    claim does not hold, 130 interrupted (Ctrl-C); raises
    :class:`DiskFull` (one line: the directory, the space free and needed) when the disk is full.
    ``make_figures(out, only=names, verbose=False) -> (files, errors)`` draws the config's figures; the
    CLI passes :func:`slamarena.paper_figures.make.make_all` (figures are the layer above this one, so
    they are handed in rather than imported). ``report`` writes ``report.html`` and ``report.md`` at the end
    (:mod:`slamarena.experiments.report`). ``force`` recomputes every cell, ``recompute`` the cells of the methods with
    these labels (:func:`~slamarena.experiments.plan.check_recompute`).
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
        failures = {i: r for i, r in ended.items() if not r.ok}
        left = len(pending) - (len(ended) - len(failures))
        if any(f.status == "disk_full" for f in failures.values()):
            raise OSError(errno.ENOSPC, "no space left on device")
        frame = collect(config, cells, failures)
        tables = write_outputs(config, cells, frame, out)
        figure_files, figure_errors = draw_figures(config, out, make_figures)
        elapsed = time.perf_counter() - t_start
        finish_manifest(manifest, out, elapsed, sorted(failures), tables, figure_files, figure_errors)
    except OSError as exc:
        if exc.errno not in DISK_FULL_ERRNOS:
            raise
        raise DiskFull(disk_full_message(out, cells, left)) from None
    console_summary(console, frame, len(pending), len(cells) - len(pending), elapsed)
    claims_hold = check_claims_of(config, out, console)
    print_results(console, out, figure_errors)
    print_next_step(console, out, write_report_html(out) if report else None)
    return 0 if (frame["status"] == "ok").all() and claims_hold else 1


def check_claims_of(config: ExperimentConfig, out: Path, console) -> bool:
    """The config's claims on the run just written (:mod:`~slamarena.experiments.claims`), printed; True if all hold."""
    if not config.claims:
        return True
    from .claims import check_claims
    from .claims import print_results as print_claims

    return print_claims(check_claims(config.claims, out), config.name, lambda line: console.print(escape(line)))
