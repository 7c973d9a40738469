"""Reading an experiment's results directory (the layout of :mod:`slamarena.experiments.results`)."""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

__all__ = ["Run", "load_runs", "by", "FigureSkipped"]


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
    def seed(self) -> int:
        return int(self.info["seed"])

    @cached_property
    def series(self) -> dict[str, np.ndarray]:
        return _npz(self.dir / "series.npz")

    @cached_property
    def truth(self) -> dict[str, np.ndarray]:
        return _npz(self.dir / "truth.npz")

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
    """Every finished cell (``metrics.json`` with status ok), ordered by dataset, method, seed."""
    runs = []
    for path in sorted(Path(results_dir).glob("runs/*/*/*/metrics.json")):
        info = json.loads(path.read_text())
        if info.get("status") == "ok":
            runs.append(Run(path.parent, info))
    if not runs:
        raise FigureSkipped(f"no finished runs under {Path(results_dir) / 'runs'}")
    return sorted(runs, key=lambda r: (r.dataset, r.estimator, r.seed))


def by(runs: list[Run], *keys: str) -> dict[tuple, list[Run]]:
    out: dict[tuple, list[Run]] = {}
    for run in runs:
        out.setdefault(tuple(getattr(run, k) for k in keys), []).append(run)
    return out
