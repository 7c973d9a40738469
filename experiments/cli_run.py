"""``slamarena run``: the options checked before anything runs, then :func:`slamarena.experiments.runner.run_experiment`
(or the ``--dry-run`` grid), and the exit code."""

from __future__ import annotations

import os
from pathlib import Path

from rich.markup import escape

from .config import ConfigError, load_config
from .console import print_grid
from .execute import SchedulerUnreachable
from .outdir import DiskFull
from .plan import UsageError, check_recompute
from .runner import FigureMaker, run_experiment

__all__ = ["run_from_cli", "check_run_options"]


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
