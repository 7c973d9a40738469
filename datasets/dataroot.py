"""Where dataset files are found: the data root.

Search order (first existing directory that holds the requested file wins):

1. an explicit root passed to :func:`set_data_root` (the CLI's ``--data-root``);
2. the environment variable ``SLAMARENA_DATA`` (``os.pathsep``-separated list allowed);
3. defaults: ``../shared/datasets`` beside this checkout, ``./shared/datasets`` and
   ``../shared/datasets`` relative to the working directory (not searched when the environment
   sets ``SLAMARENA_SEARCH_SHARED=0``: a machine without the shared folder, as a fresh clone has),
   and the download cache (``$SLAMARENA_CACHE`` or ``~/.cache/slamarena``) where
   ``slamarena data fetch`` puts files.

Files are never copied into the repository.
"""
from __future__ import annotations

import os
from pathlib import Path

from .errors import DatasetNotFoundError

__all__ = ["set_data_root", "data_roots", "find", "cache_dir"]

_explicit: list[Path] = []


def set_data_root(root: str | Path | None) -> None:
    """Put ``root`` first in the search order (``None`` clears it)."""
    _explicit.clear()
    if root is not None:
        _explicit.append(Path(root).expanduser().resolve())


def cache_dir() -> Path:
    """Directory where fetched datasets are stored."""
    return Path(os.environ.get("SLAMARENA_CACHE", Path.home() / ".cache" / "slamarena")).expanduser()


def data_roots(existing_only: bool = True) -> list[Path]:
    """The data roots in search order (deduplicated)."""
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


def find(relative: str | Path, dataset: str) -> Path:
    """Absolute path of ``relative`` under the first data root that has it.

    Raises :class:`DatasetNotFoundError` listing every place searched and the fetch command.
    """
    for root in data_roots():
        path = root / relative
        if path.exists():
            return path
    raise DatasetNotFoundError(dataset, data_roots(existing_only=False), str(relative))
