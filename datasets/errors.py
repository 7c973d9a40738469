"""The errors of the data layer (all are :class:`~slamarena.errors.UserError`: the CLI prints their message alone) and its warning."""

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


class DatasetNameError(UserError, ValueError):
    """A dataset name and parameters that do not go together: a catalogued name given another location, a location
    given twice (in the name and in the parameters), a ``<family>:<path>`` not in the family's form."""


class DataWarning(UserWarning):
    """A reader repaired its input locally (dropped a damaged line, say): the message names the file and the first
    line; ``meta`` of the result lists them all. Shown on the console by Python's default warning filter."""


class DatasetNotFoundError(UserError, FileNotFoundError):
    """A dataset whose files no place holds all of: names every place searched and what it lacks, then what to do.

    ``lacking`` lists (place, [candidates of each missing file]) in search order; ``relative`` is the first missing
    file as the dataset names it."""

    def __init__(self, name: str, lacking: list, advice: str):
        self.name = name
        self.lacking = lacking
        self.relative = lacking[0][1][0][0] if lacking and lacking[0][1] else ""
        lines = [line for place, missing in lacking for line in place.lacks(missing)]
        places = "\n".join(dict.fromkeys(lines))
        super().__init__(f"dataset {name!r} not found: no place holds all its files. Missing:\n{places}\n{advice}")
