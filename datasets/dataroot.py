"""Where dataset files are found: the data roots, and the example data inside the GTSAM wheel.

A file is named by its path relative to a data root (``sesync_g2o/intel.g2o``). Search order (the
first place that holds the requested file wins):

1. an explicit root passed to :func:`set_data_root` (the CLI's ``--data-root``);
2. the environment variable ``SLAMARENA_DATA`` (``os.pathsep``-separated list allowed);
3. defaults: ``../shared/datasets`` beside this checkout, ``./shared/datasets`` and
   ``../shared/datasets`` relative to the working directory (not searched when the environment
   sets ``SLAMARENA_SEARCH_SHARED=0``: a machine without the shared folder, as a fresh clone has),
   and the download cache (``$SLAMARENA_CACHE`` or ``~/.cache/slamarena``) where
   ``slamarena data fetch`` puts files;
4. the example data that ships inside the GTSAM wheel (``gtsam.findExampleDataFile``): a root of
   its own kind, with no folder layout of ours — :data:`GTSAM_WHEEL` maps the relative path of each
   staged file of which the wheel holds a byte-identical copy (decompressed, for a staged ``.gz``)
   to the wheel's file name. So the GTSAM toy graphs, CMU Plaza and Victoria Park load on any
   machine with ``gtsam`` installed, while a staged copy, when there is one, is read first.

Files are never copied into the repository.
"""
from __future__ import annotations

import os
from pathlib import Path

from .errors import DatasetNotFoundError

__all__ = ["set_data_root", "data_roots", "locate", "find", "cache_dir", "gtsam_example", "GTSAM_WHEEL"]

_explicit: list[Path] = []

#: relative path of a staged file → the name of its copy in the GTSAM wheel's example data (same content,
#: checked by tests/datasets/test_dataroot.py against the staged files)
GTSAM_WHEEL: dict[str, str] = {
    **{f"gtsam_examples_data/{name}": name for name in (
        "noisyToyGraph.txt", "optimizedNoisyToyGraph.txt", "orientationsNoisyToyGraph.txt", "pose2example.txt",
        "toyExample.g2o", "Klaus3.g2o", "pose3example.txt", "pose3example-grid.txt", "simpleGraph10gradIter.txt",
        "w100.graph", "example.graph")},
    "gtsam_examples_data/w20000.txt.gz": "w20000.txt",
    **{f"plaza_range_only/{run}{part}": f"{run}{part}" for run in ("Plaza1", "Plaza2") for part in ("_DR.txt", "_TD.txt", "_.mat")},
    "victoria_park/victoria_park_gtsam.txt": "victoria_park.txt",
}


def set_data_root(root: str | Path | None) -> None:
    """Put ``root`` first in the search order (``None`` clears it)."""
    _explicit.clear()
    if root is not None:
        _explicit.append(Path(root).expanduser().resolve())


def cache_dir() -> Path:
    """Directory where fetched datasets are stored."""
    return Path(os.environ.get("SLAMARENA_CACHE", Path.home() / ".cache" / "slamarena")).expanduser()


def data_roots(existing_only: bool = True) -> list[Path]:
    """The data root folders in search order (deduplicated); the GTSAM wheel comes after them (:func:`locate`)."""
    candidates: list[Path] = list(_explicit)
    env = os.environ.get("SLAMARENA_DATA")
    if env:
        candidates += [Path(p).expanduser() for p in env.split(os.pathsep) if p]
    if os.environ.get("SLAMARENA_SEARCH_SHARED", "1") != "0":
        checkout = Path(__file__).resolve().parent.parent
        candidates += [checkout.parent / "shared" / "datasets", Path.cwd() / "shared" / "datasets", Path.cwd().parent / "shared" / "datasets"]
    candidates.append(cache_dir())
    seen: list[Path] = []
    for c in candidates:
        c = c.resolve()
        if c not in seen and (c.is_dir() or not existing_only):
            seen.append(c)
    return seen


def gtsam_example(relative: str | Path) -> Path | None:
    """The GTSAM wheel's copy of the staged file ``relative`` (``None``: the wheel has none, or gtsam is not installed)."""
    name = GTSAM_WHEEL.get(Path(relative).as_posix())
    if name is None:
        return None
    try:
        import gtsam
    except ImportError:
        return None
    try:
        return Path(gtsam.findExampleDataFile(name))
    except OSError:  # FileNotFoundError: a wheel built without its example data
        return None


def locate(relative: str | Path) -> Path | None:
    """Absolute path of ``relative`` in the first place of the search order that has it (``None``: nowhere)."""
    for root in data_roots():
        path = root / relative
        if path.exists():
            return path
    return gtsam_example(relative)


def find(relative: str | Path, dataset: str) -> Path:
    """:func:`locate`, raising :class:`DatasetNotFoundError` (every place searched and the fetch command) when nowhere."""
    path = locate(relative)
    if path is None:
        raise DatasetNotFoundError(dataset, data_roots(existing_only=False), str(relative))
    return path
