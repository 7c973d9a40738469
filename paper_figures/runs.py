"""Reading an experiment's results directory (the layout of :mod:`slamarena.experiments.results`)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

__all__ = ["Run", "load_runs", "load_manifest", "config_entries", "by", "FigureSkipped"]


class FigureSkipped(Exception):
    """The results hold nothing this figure can show (the reason is reported)."""


@dataclass(frozen=True)
class Run:
    dir: Path
    info: dict

    @property
    def dataset(self) -> str:
        return self.info["dataset"]["label"]

    @property
    def estimator(self) -> str:
        return self.info["estimator"]["label"]

    @property
    def method(self) -> str:
        """The registry name of the run's method (``estimator`` is its label in the run)."""
        return self.info["estimator"]["name"]

    @property
    def seed(self) -> int:
        return int(self.info["seed"])

    @cached_property
    def series(self) -> dict[str, np.ndarray]:
        return _npz(self.dir / "series.npz")

    @cached_property
    def truth(self) -> dict[str, np.ndarray]:
        return _npz(self.dir / "truth.npz")

    @cached_property
    def alignment(self):
        """The cell's ATE alignment (``metrics.json`` ``alignment``; the identity without one): estimate → ground-truth frame."""
        from slamarena.experiments.metrics.alignment import Alignment

        a = self.info.get("alignment") or {}
        return Alignment(a.get("angle", 0.0), (a.get("tx", 0.0), a.get("ty", 0.0)), a.get("scale", 1.0))

    @cached_property
    def estimate(self):
        from slamarena.datasets.estimate import Estimate

        return Estimate.load(self.dir / "estimate.npz")


def _npz(path: Path) -> dict[str, np.ndarray]:
    if not path.exists():
        return {}
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def load_runs(results_dir: str | Path) -> list[Run]:
    """Every finished cell (``metrics.json`` with status ok), ordered by dataset and method as the run's config
    lists them (:func:`config_entries`; others after them, by name), then seed."""
    runs = []
    for path in sorted(Path(results_dir).glob("runs/*/*/*/metrics.json")):
        info = json.loads(path.read_text())
        if info.get("status") == "ok":
            runs.append(Run(path.parent, info))
    if not runs:
        raise FigureSkipped(f"no finished runs under {Path(results_dir) / 'runs'}")
    datasets = [label for label, _ in config_entries(results_dir, "datasets")]
    methods = [label for label, _ in config_entries(results_dir, "estimators")]

    def rank(order: list[str], label: str) -> tuple[int, str]:
        return (order.index(label) if label in order else len(order), label)

    return sorted(runs, key=lambda r: (rank(datasets, r.dataset), rank(methods, r.estimator), r.seed))


def config_entries(results_dir: str | Path, kind: str) -> list[tuple[str, str]]:
    """(label, registry name) of the config's ``datasets`` or ``estimators`` in their order (``manifest.json``)."""
    from slamarena.experiments.config import sanitize

    return [
        (spec.get("label") or sanitize(spec["name"]), spec["name"])
        for spec in load_manifest(results_dir).get("config", {}).get(kind, [])
    ]


def load_manifest(results_dir: str | Path) -> dict:
    """The run's ``manifest.json`` (empty where there is none, e.g. cells copied by hand)."""
    path = Path(results_dir) / "manifest.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def by(runs: list[Run], *keys: str) -> dict[tuple, list[Run]]:
    out: dict[tuple, list[Run]] = {}
    for run in runs:
        out.setdefault(tuple(getattr(run, k) for k in keys), []).append(run)
    return out
