"""The one base of errors a user can fix: bad input files, missing data, bad configurations and options.

The command line prints such an error's message alone and exits with code 2; any other exception is a
bug of slamarena and keeps its traceback (``slamarena.experiments.cli.main``)."""

from __future__ import annotations

__all__ = ["UserError", "UnknownNameError"]


class UserError(Exception):
    """An error in what the user gave (a file, a dataset name, a config, an option); its message says what and where."""


class UnknownNameError(UserError, KeyError):
    """A registry name (dataset, method, matcher) that is not registered; the message lists the known ones."""

    def __str__(self) -> str:  # KeyError would show the message in quotes
        return str(self.args[0]) if self.args else ""
