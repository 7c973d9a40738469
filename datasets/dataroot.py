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

A dataset's files all come from ONE root (:func:`one_root`): the first, in this order, that holds every
file the dataset requires; its optional files are read from that root or not at all. Mixing roots
would pair one recording's odometry with another's ground truth (or leave the ground truth out
silently). A path a user gives for a format family is searched the same way, with the working
directory as the first root (an absolute path is the same file under every root).

Files are never copied into the repository.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from .errors import DatasetNotFoundError
from .source import Layout

__all__ = [
    "set_data_root",
    "data_roots",
    "locate",
    "cache_dir",
    "gtsam_example",
    "GTSAM_WHEEL",
    "Directory",
    "GtsamWheel",
    "roots",
    "one_root",
]

_explicit: list[Path] = []

#: relative path of a staged file → the name of its copy in the GTSAM wheel's example data (same content,
#: checked by tests/datasets/test_dataroot.py against the staged files)
GTSAM_WHEEL: dict[str, str] = {
    **{
        f"gtsam_examples_data/{name}": name
        for name in (
            "noisyToyGraph.txt",
            "optimizedNoisyToyGraph.txt",
            "orientationsNoisyToyGraph.txt",
            "pose2example.txt",
            "toyExample.g2o",
            "Klaus3.g2o",
            "pose3example.txt",
            "pose3example-grid.txt",
            "simpleGraph10gradIter.txt",
            "w100.graph",
            "example.graph",
        )
    },
    "gtsam_examples_data/w20000.txt.gz": "w20000.txt",
    **{
        f"plaza_range_only/{run}{part}": f"{run}{part}"
        for run in ("Plaza1", "Plaza2")
        for part in ("_DR.txt", "_TD.txt", "_.mat")
    },
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
        candidates += [
            checkout.parent / "shared" / "datasets",
            Path.cwd() / "shared" / "datasets",
            Path.cwd().parent / "shared" / "datasets",
        ]
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
    """The file ``relative`` in the first place of :func:`roots` that has it (``None``: nowhere): one file on its own."""
    return next((path for place in roots() if (path := place.file(str(relative))) is not None), None)


@dataclass(frozen=True)
class Directory:
    """A data root folder (or, for a user's path, the working directory)."""

    path: Path

    def file(self, relative: str) -> Path | None:
        path = self.path / relative
        return path if path.is_file() else None

    def lacks(self, missing: list[tuple[str, ...]]) -> list[str]:
        """Lines of a message naming the ``missing`` files (each its candidates) here; an absolute path is itself."""
        lines = []
        for candidates in missing:
            if not (self.path.is_dir() or Path(candidates[0]).is_absolute()):
                return [f"  - {self.path} (does not exist)"]
            lines.append(f"  - {' or '.join(str(self.path / c) for c in candidates)}")
        return lines


class GtsamWheel:
    """The GTSAM wheel's example data as a root: the staged paths of :data:`GTSAM_WHEEL`, nothing else."""

    def file(self, relative: str) -> Path | None:
        return gtsam_example(relative)

    def lacks(self, missing: list[tuple[str, ...]]) -> list[str]:
        relative = [candidates[0] for candidates in missing if not Path(candidates[0]).is_absolute()]
        return [f"  - the GTSAM wheel's example data: no copy of {', '.join(relative)}"] if relative else []


def roots(first: tuple[Path, ...] = ()) -> list[Directory | GtsamWheel]:
    """The places searched, in order: ``first``, the data roots (existing or not: a message lists them all), the wheel."""
    places = [*(Path(p).resolve() for p in first), *data_roots(existing_only=False)]
    return [Directory(p) for p in dict.fromkeys(places)] + [GtsamWheel()]


def one_root(layout: Layout, places: list, dataset: str, advice: str) -> dict[str, Path]:
    """Role → path of the files of ``layout``, every one from the first of ``places`` that holds all the required ones
    (an optional file only from that place); :class:`DatasetNotFoundError` naming what each place lacks otherwise."""
    lacking = []
    for place in places:
        found = {
            role: next((p for p in map(place.file, candidates) if p is not None), None)
            for role, candidates in layout.files.items()
        }
        missing = [role for role in layout.required() if found[role] is None]
        if not missing:
            return {role: path for role, path in found.items() if path is not None}
        lacking.append((place, [layout.files[role] for role in missing]))
    raise DatasetNotFoundError(dataset, lacking, advice)
