"""What a run prints: progress as cells end, the end-of-run table, and the ``--dry-run`` grid."""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

from rich.markup import escape

from .cellspec import CellOutcome
from .config import ExperimentConfig
from .plan import forced_cells, plan

__all__ = ["progress", "ProgressLines", "console_summary", "print_results", "print_next_step", "print_grid"]


def progress(console):
    """On a terminal, a progress bar; otherwise (stderr to a file: nohup, tee, CI) :class:`ProgressLines`."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    if not console.is_terminal:
        return ProgressLines(console)
    return Progress(
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

    def finished(self, result: CellOutcome, failed: int) -> None:
        self.done += 1
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        status = result.status + ("" if result.ok else f" ({result.error})")
        self.console.print(
            escape(
                f"[{self.done}/{self.total}] {result.id} {status} {result.elapsed:.1f} s · {failed} failed · "
                f"{_clock(elapsed)} elapsed, ETA {_clock(eta)}"
            ),
            highlight=False,
            soft_wrap=True,
        )


def _clock(seconds: float) -> str:
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes}:{secs:02d}" if minutes < 60 else f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


def console_summary(console, frame, cells_run: int, cached: int, elapsed: float) -> None:
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


def print_results(console, out: Path, figure_errors: dict) -> None:
    """After the table: the figures not drawn (and why), and where the results are."""
    for name, err in figure_errors.items():
        console.print(f"[yellow]figure {escape(name)} not drawn: {escape(str(err))}[/yellow]")
    console.print(f"results: {escape(str(out))}", highlight=False)


def print_next_step(console, out: Path, report_html: Path | None) -> None:
    """The last line: the report written, or the command that writes it."""
    if report_html is not None:
        console.print(f"report: {escape(str(report_html))} (open it in a browser)", highlight=False)
    else:
        console.print(
            f"next: slamarena report {escape(shlex.quote(str(out)))}  (every table and figure on one page, report.html)",
            highlight=False,
        )


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
