"""``manifest.json`` of a run: the config, the resolved parameters, the versions of the libraries, the git revision,
the machine, the command, and when the run started, finished or was interrupted."""

from __future__ import annotations

import os
import platform
import shlex
import socket
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

from rich.markup import escape

from .config import ExperimentConfig
from .plan import Cell
from .results import MANIFEST, write_json

__all__ = ["start_manifest", "finish_manifest", "record_interruption", "now"]


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


def now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


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
        "started": now(),
        "finished": None,
        "interrupted": None,
        "cells": {"total": len(cells), "to_run": len(pending), "cached": len(cells) - len(pending)},
    }
    write_json(out / MANIFEST, manifest)
    return manifest


def finish_manifest(
    manifest: dict,
    out: Path,
    elapsed: float,
    failed: list[str],
    tables: list[Path],
    figures: list,
    figure_errors: dict,
) -> None:
    """Complete ``manifest.json`` as the run ends: when, how long, the failed cells, the tables and figures written
    (relative to ``out``) and the figures not drawn with why."""
    manifest.update(
        finished=now(),
        duration_s=elapsed,
        failed=failed,
        tables=[str(p.relative_to(out)) for p in tables],
        figures=[str(Path(p).relative_to(out)) for p in figures],
        figure_errors=figure_errors,
    )
    write_json(out / MANIFEST, manifest)


def record_interruption(manifest: dict, out: Path, cells: list[Cell], console) -> None:
    """After Ctrl-C: the manifest says so, and the console says what finished and how to resume."""
    done = sum(c.finished() for c in cells)
    manifest["interrupted"] = {"at": now(), "finished_cells": done, "total_cells": len(cells)}
    write_json(out / MANIFEST, manifest)
    command = " ".join(shlex.quote(a) for a in (manifest["command"] or ["slamarena", "run"]))
    console.print(
        f"[yellow]interrupted: {done} of {len(cells)} cells are finished and kept in {escape(str(out))}.[/yellow]"
    )
    console.print(f"resume with the same command (finished cells are skipped): {escape(command)}", highlight=False)
