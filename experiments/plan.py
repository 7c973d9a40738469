"""The plan of a run: the grid of cells (datasets × methods × seeds), each with its directory and cache keys, and
the :class:`~slamarena.experiments.cellspec.CellSpec` a cell process gets.

The grid: a method with a ``datasets:`` list runs only on those. A simulator gets the cell's seed; a real dataset is
the same for every seed, so a method that takes no ``seed`` runs once on it (the first seed) instead of repeating an
identical computation.

A cell's cache key is the SHA-256 of the dataset spec (name, parameters, the seed of a simulator), the SHA-256 of
every file of a real dataset (``slamarena.datasets.catalogue``), the method spec, the seed and the slamarena version;
its metrics key adds the metric settings. A cell is finished (:meth:`Cell.finished`) when its ``metrics.json`` carries
both keys and the SHA-256 of the files its numbers were computed from still match.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from slamarena.errors import UserError

from .cell import CACHED_FILES, file_digest
from .cellspec import CellDataset, CellMethod, CellSpec
from .config import ExperimentConfig
from .results import cell_dir, read_json, sha256_file

__all__ = [
    "Cell",
    "plan",
    "forced_cells",
    "check_recompute",
    "UsageError",
    "cell_env",
    "cell_spec",
    "package_version",
    "dataset_checksums",
]


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


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def dataset_checksums(name: str, params: dict) -> dict[str, str]:
    """SHA-256 of each file of a real dataset (empty for simulators)."""
    from slamarena.datasets.registry import SIMULATORS, resolve

    if name in SIMULATORS:
        return {}
    return {role: sha256_file(path) for role, path in resolve(name, params).files().items()}


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
                            **({"landmarks": ds.resolved_landmarks()} if ds.landmarks is not None else {}),
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


def forced_cells(config: ExperimentConfig, cells: list[Cell], force: bool, recompute: frozenset[str]) -> set[str]:
    """Ids of the cells recomputed even if cached: all with ``force``, else those of the methods labelled in ``recompute``."""
    labels = config.estimator_labels()
    return {c.id for c in cells if force or labels[c.estimator] in recompute}


class UsageError(UserError, ValueError):
    """A command-line value that cannot work (the message says which and why)."""


def check_recompute(config: ExperimentConfig, recompute: frozenset[str]) -> None:
    """Refuse a ``--recompute`` label that names no method of the config (UsageError, the known labels listed)."""
    unknown = sorted(set(recompute) - set(config.estimator_labels()))
    if unknown:
        raise UsageError(
            f"--recompute {', '.join(unknown)}: no such method label in {config.name}; "
            f"its labels: {', '.join(config.estimator_labels())}"
        )


def cell_env(config: ExperimentConfig) -> dict:
    """Variables a cell process gets on top of its worker's environment: the data roots in use here, and one
    thread for BLAS, OpenMP and numba if the config asks for single-threaded cells."""
    from slamarena.datasets.dataroot import data_roots

    from .benchmarks import SINGLE_THREAD_ENV

    return {
        "SLAMARENA_DATA": os.pathsep.join(str(p) for p in data_roots()),
        **(SINGLE_THREAD_ENV if config.single_threaded else {}),
    }


def cell_spec(config: ExperimentConfig, cell: Cell, env: dict, force: bool = False) -> CellSpec:
    """What the process of ``cell`` gets: the cell's dataset and method as the config states them, its keys and
    directory, the metric settings, ``env`` (:func:`cell_env`), and ``force`` (recompute even a cached estimate)."""
    ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
    return CellSpec(
        id=cell.id,
        dir=str(cell.dir),
        key=cell.key,
        metrics_key=cell.metrics_key,
        seed=cell.seed,
        dataset=CellDataset(
            ds.name, ds.params, config.dataset_labels()[cell.dataset], ds.is_simulator, ds.resolved_landmarks()
        ),
        estimator=CellMethod(es.name, es.params, config.estimator_labels()[cell.estimator]),
        seed_to_estimator=cell.seed_to_estimator,
        metrics={k: v.model_dump(mode="json") for k, v in config.enabled_metrics().items()},
        env=env,
        force=force,
        mcap=config.mcap,
    )
