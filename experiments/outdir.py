"""The results directory while a run writes into it: the lock two runs into one directory share, and a full disk."""

from __future__ import annotations

import os
import socket
from contextlib import contextmanager
from pathlib import Path

from rich.markup import escape

from slamarena.errors import UserError

from .manifest import now
from .plan import Cell
from .results import LOCK

__all__ = ["DiskFull", "disk_full_message", "results_lock"]


class DiskFull(UserError, OSError):
    """The disk holding the results directory is full (the message names it and the space the run still needs)."""


def disk_full_message(out: Path, cells: list[Cell], left: int) -> str:
    """One line: where, how much is free, and about how much the ``left`` cells not finished by this run need (the
    mean size of the directories of the cells with a ``metrics.json`` times that count)."""
    import shutil

    def mb(n: float) -> str:
        return f"{n / 2**20:.0f} MB" if n >= 2**20 else f"{n / 2**10:.0f} kB"

    finished = [c for c in cells if (c.dir / "metrics.json").is_file()]
    sizes = [sum(f.stat().st_size for f in c.dir.iterdir() if f.is_file()) for c in finished]
    free = shutil.disk_usage(out).free
    if sizes and left:
        per = sum(sizes) / len(sizes)
        need = f"the {left} cells left need about {mb(per * left)} ({mb(per)} each) plus the tables and figures"
    elif not left:
        need = "every cell is finished; the tables and figures need a few MB"
    else:
        need = f"no cell finished to measure a cell's size ({left} cells left)"
    return (
        f"disk full: no space left writing to {out} ({mb(free)} free; {need}); "
        f"free some space and run the same command again (finished cells are kept)"
    )


@contextmanager
def results_lock(out: Path, console):
    """Hold ``out/.lock`` (``flock``, released by the kernel if this process dies) while a run writes into ``out``. A
    second run into the same directory says which run holds it (pid, host, since when) and waits for it; then it
    skips the cells that run finished."""
    import fcntl

    with open(out / LOCK, "a+") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "another run"
            console.print(
                f"[yellow]{escape(str(out))} is in use by {escape(holder)}; waiting for it to end "
                f"(Ctrl-C to stop)[/yellow]",
                highlight=False,
            )
            fcntl.flock(fh, fcntl.LOCK_EX)
        fh.seek(0)
        fh.truncate()
        fh.write(f"slamarena run pid {os.getpid()} on {socket.gethostname()} since {now()}\n")
        fh.flush()
        yield
