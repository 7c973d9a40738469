"""The errors of the data layer (both are :class:`~slamarena.errors.UserError`: the CLI prints their message alone) and its warning."""
from __future__ import annotations

from pathlib import Path

from slamarena.errors import UserError


class DataFormatError(UserError, ValueError):
    """A malformed input file: names the file, the line number (1-based) and what was expected."""

    def __init__(self, path: str | Path, line: int | None, expected: str, got: str | None = None):
        self.path = str(path)
        self.line = line
        self.expected = expected
        self.got = got
        where = f"{self.path}:{line}" if line is not None else self.path
        message = f"{where}: expected {expected}"
        if got is not None:
            message += f", got {got!r}"
        super().__init__(message)


class DataWarning(UserWarning):
    """A reader repaired its input locally (dropped a damaged line, say): the message names the file and the first
    line; ``meta`` of the result lists them all. Shown on the console by Python's default warning filter."""


class DatasetNotFoundError(UserError, FileNotFoundError):
    """A dataset whose files are not under any data root."""

    def __init__(self, name: str, looked_in: list[Path], relative: str):
        self.name = name
        self.looked_in = looked_in
        self.relative = relative
        places = "\n".join(f"  - {p / relative}" for p in looked_in) or "  (no data root exists)"
        super().__init__(
            f"dataset {name!r} not found: no data root holds {relative}. Looked in:\n{places}\n"
            f"Set --data-root or SLAMARENA_DATA, or download it with: slamarena data fetch {name}"
        )
