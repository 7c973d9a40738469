"""Running the pending cells of a run, each in a process of its own (:mod:`slamarena.experiments.cell`).

Locally, ``jobs`` threads each feed one long-lived worker (:class:`slamarena.experiments.cell.Worker`: it imports the
libraries once and forks a child per cell; the work, the timeout kill and the memory peak belong to the child); the
first cell of each method runs before that method's others (:class:`CellQueue`), so its numba kernels are compiled
once, into numba's cache, not by several cells at once. On a Dask distributed cluster (``scheduler``) each cell is a
fresh process (:func:`slamarena.experiments.cell.run_cell`). A failing or timed-out cell does not stop the others; a
cell that found the disk full stops the run.
"""

from __future__ import annotations

import threading

from slamarena.errors import UserError

from .cellspec import CellOutcome, CellSpec

__all__ = ["execute", "CellQueue", "SchedulerUnreachable"]


class SchedulerUnreachable(UserError, RuntimeError):
    """``--scheduler`` names an address where no Dask scheduler answers."""


def execute(
    specs: list[CellSpec], timeout: float | None, jobs: int, scheduler: str | None, on_done
) -> list[CellOutcome]:
    """Run the pending cells, each in its own process: on ``jobs`` local workers, or on a Dask cluster.

    ``on_done(result)`` is called as each cell ends; a cell that found the disk full stops the run (the cells
    not started yet are left for the next run). On Ctrl-C the cells still running are killed and
    ``KeyboardInterrupt`` propagates to the caller, which records the interruption.
    """
    from .cell import terminate_all

    if not specs:
        return []
    try:
        if scheduler:
            return _execute_dask(specs, timeout, scheduler, on_done)
        return _execute_local(specs, timeout, jobs, on_done)
    except KeyboardInterrupt:
        terminate_all()
        raise


class CellQueue:
    """The pending cells in plan order, handed to the job slots one at a time. The first cell of each method runs
    before that method's other cells: it compiles the method's numba kernels (into numba's on-disk cache) while the
    other slots run other methods, and the method's later cells load them instead of compiling them again at once."""

    def __init__(self, specs: list[CellSpec]):
        self._pending = list(specs)
        self._started: set[str] = set()  # methods whose first cell was handed out
        self._released: set[str] = set()  # methods whose first cell has ended
        self._closed = False
        self._cond = threading.Condition()

    def take(self) -> CellSpec | None:
        """The next cell that may start (waiting while only held-back cells are left); None when none is left."""
        with self._cond:
            while not self._closed and self._pending:
                for i, spec in enumerate(self._pending):
                    method = spec.estimator.name
                    if method in self._released or method not in self._started:
                        self._started.add(method)
                        return self._pending.pop(i)
                self._cond.wait()
            return None

    def done(self, spec: CellSpec) -> None:
        with self._cond:
            self._released.add(spec.estimator.name)
            self._cond.notify_all()

    def close(self) -> None:
        """Hand out nothing more (the cells running finish)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()


def _execute_local(specs: list[CellSpec], timeout: float | None, jobs: int, on_done) -> list[CellOutcome]:
    """``jobs`` threads, each feeding cells from a :class:`CellQueue` to its own
    :class:`~slamarena.experiments.cell.Worker` (a process that has imported everything once and forks a child per
    cell); the main thread reports each result as it comes."""
    import queue

    from .cell import Worker

    cells, ended = CellQueue(specs), queue.Queue()

    def slot() -> None:
        worker = Worker(specs[0].env)
        try:
            while (spec := cells.take()) is not None:
                result = worker.run(spec, timeout)
                cells.done(spec)
                ended.put(result)
        finally:
            worker.close()

    threads = [threading.Thread(target=slot, daemon=True) for _ in range(min(jobs, len(specs)))]
    for thread in threads:
        thread.start()
    results = []
    try:
        while any(t.is_alive() for t in threads) or not ended.empty():
            try:
                result = ended.get(timeout=0.2)
            except queue.Empty:
                continue
            results.append(result)
            on_done(result)
            if result.status == "disk_full":
                cells.close()
    finally:
        cells.close()
    return results


def _execute_dask(specs: list[CellSpec], timeout: float | None, scheduler: str, on_done) -> list[CellOutcome]:
    from distributed import Client, as_completed

    from .cell import run_cell

    try:
        client = Client(scheduler, timeout="20s")
    except (OSError, ValueError, TypeError) as exc:
        raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None
    results = []
    with client:
        futures = client.map(run_cell, specs, [timeout] * len(specs), pure=False)
        try:
            for future in as_completed(futures):
                result = future.result()
                results.append(result)
                on_done(result)
        except KeyboardInterrupt:
            client.cancel(futures)
            raise
    return results
