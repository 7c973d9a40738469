"""The first run and its guards: long-lived workers, the first cell of a method before its others, progress lines
without a terminal, the next step named, a locked results directory, cached files checked by digest, a full disk."""

from __future__ import annotations

import errno
import fcntl
import io
import json
import os
import textwrap
import threading
import time

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from slamarena.experiments.config import load_config
from slamarena.experiments.plan import plan
from slamarena.experiments.runner import run_experiment

TINY = """
name: tiny
seeds: 2
timeout: 120
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
estimators:
  - name: dead_reckoning
metrics: [ate, cost]
figures: []
"""


def _config(tmp_path, text=TINY):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    return load_config(path)


def _log_console() -> tuple[Console, io.StringIO]:
    """A console that is not a terminal (stderr to a file, as under nohup, tee or CI)."""
    buffer = io.StringIO()
    return Console(file=buffer, width=200, force_terminal=False), buffer


def _temporaries(out):
    return [p for p in out.rglob("*") if p.name.endswith(".tmp")]


def test_without_a_terminal_each_finished_cell_is_a_line_with_counts_and_eta_and_the_end_names_the_next_step(tmp_path):
    console, buffer = _log_console()
    out = tmp_path / "out"
    assert run_experiment(_config(tmp_path), out, jobs=2, console=console) == 0
    text = buffer.getvalue()
    lines = [line for line in text.splitlines() if line.startswith("[")]
    assert len(lines) == 2, text
    assert {line.split()[0] for line in lines} == {"[1/2]", "[2/2]"}
    for line in lines:
        assert "sim_landmarks/dead_reckoning/" in line and " ok " in line and "0 failed" in line and "ETA" in line
    assert f"next: slamarena report {out}" in text


def test_cells_of_one_worker_are_separate_processes_and_a_dead_worker_is_replaced(tmp_path):
    from slamarena.experiments.cell import Worker
    from slamarena.experiments.plan import cell_env, cell_spec

    cfg = _config(tmp_path)
    cells = plan(cfg, tmp_path / "out")
    env = cell_env(cfg)
    worker = Worker(env)
    try:
        first = worker.run(cell_spec(cfg, cells[0], env), 120)
        server = worker.proc.pid
        second = worker.run(cell_spec(cfg, cells[1], env), 120)
        assert first.status == second.status == "ok"
        assert worker.proc.pid == server  # one worker served both
        pids = [json.loads((c.dir / "metrics.json").read_text())["pid"] for c in cells]
        assert len(set(pids)) == 2 and server not in pids  # each cell in a process of its own
        worker.proc.kill()
        worker.proc.wait()
        again = worker.run(cell_spec(cfg, cells[0], env, force=True), 120)
        assert again.status == "ok" and worker.proc.pid != server
    finally:
        worker.close()


def test_the_first_cell_of_a_method_runs_before_its_others():
    from slamarena.experiments.cellspec import CellDataset, CellMethod, CellSpec
    from slamarena.experiments.execute import CellQueue

    def spec(method, k):
        dataset = CellDataset("sim:landmarks", {}, "sim_landmarks", True)
        return CellSpec(f"{method}{k}", "/x", "", "", k, dataset, CellMethod(method, {}, method), False, {})

    specs = [spec(m, k) for m in ("ekf", "fast") for k in range(2)]
    queue = CellQueue(specs)
    assert [queue.take().id, queue.take().id] == ["ekf0", "fast0"]  # ekf1 held back while ekf0 runs
    taken = []
    waiter = threading.Thread(target=lambda: taken.append(queue.take().id))
    waiter.start()
    waiter.join(0.3)
    assert waiter.is_alive() and not taken  # nothing may start: both methods' first cells are running
    queue.done(specs[2])  # fast0 ended: its kernels are compiled
    waiter.join(5)
    assert taken == ["fast1"]
    queue.done(specs[0])
    assert queue.take().id == "ekf1" and queue.take() is None


def test_a_timeout_after_compilation_says_so_and_the_compile_clock_counts_compilation_once():
    from numba import njit

    from slamarena.experiments.cell import outcome
    from slamarena.experiments.compilation import CompileClock

    result = outcome("a/b/0", "/x", None, 300.2, timeout=300, compile_s=212.4)
    assert result.status == "timeout"
    assert result.error == "timed out after 300 s (killed); 212 s of it compiling numba kernels"
    assert "compiling" not in outcome("a/b/0", "/x", None, 1.0, timeout=1, compile_s=0.0).error

    @njit
    def inner(x):
        return x + 1.0

    @njit
    def outer(x):
        return inner(x) * 2.0

    seen = []
    with CompileClock(seen.append) as clock:
        assert outer(1.0) == 4.0
    assert clock.seconds > 0 and seen == [clock.seconds]  # the nested compilation of inner counted with outer's
    with CompileClock() as again:
        outer(2.0)
    assert again.seconds == 0.0  # compiled already


def test_a_second_run_into_the_same_directory_waits_and_says_what_holds_it(tmp_path):
    from slamarena.experiments.results import LOCK

    out = tmp_path / "out"
    out.mkdir()
    holder = open(out / LOCK, "a+")
    fcntl.flock(holder, fcntl.LOCK_EX)
    holder.write("slamarena run pid 4242 on elsewhere since 2026-11-28T05:00:00+00:00\n")
    holder.flush()
    console, buffer = _log_console()
    codes = []
    second = threading.Thread(target=lambda: codes.append(run_experiment(_config(tmp_path), out, console=console)))
    second.start()
    deadline = time.monotonic() + 30
    while "in use" not in buffer.getvalue() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    assert second.is_alive() and not (out / "runs").exists()  # waiting, nothing computed
    assert "in use by slamarena run pid 4242 on elsewhere since 2026-11-28T05:00:00+00:00" in buffer.getvalue()
    fcntl.flock(holder, fcntl.LOCK_UN)
    holder.close()
    second.join(120)
    assert codes == [0]
    assert f"pid {os.getpid()}" in (out / LOCK).read_text()


def test_two_runs_at_once_compute_each_cell_once(tmp_path):
    cfg = _config(tmp_path, TINY.replace("seeds: 2", "seeds: 3"))
    out = tmp_path / "out"
    quiet = lambda: Console(file=io.StringIO())  # noqa: E731
    codes = []
    runs = [threading.Thread(target=lambda: codes.append(run_experiment(cfg, out, console=quiet()))) for _ in range(2)]
    for run in runs:
        run.start()
    for run in runs:
        run.join(300)
    assert codes == [0, 0]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["cells"] == {"total": 3, "to_run": 0, "cached": 3}  # the second found every cell finished


def test_an_edited_cached_estimate_is_recomputed_and_the_summary_matches_the_file(tmp_path):
    """A whole, readable ``estimate.npz`` with a NaN pose put in after the run: not reused."""
    from slamarena import datasets
    from slamarena.datasets.estimate import Estimate
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ate

    cfg = _config(tmp_path, TINY.replace("seeds: 2", "seeds: 1"))
    out = tmp_path / "out"
    quiet = Console(file=io.StringIO())
    assert run_experiment(cfg, out, console=quiet) == 0
    [cell] = plan(cfg, out)
    estimate = Estimate.load(cell.dir / "estimate.npz")
    estimate.poses[5, 0] = np.nan
    estimate.save(cell.dir / "estimate.npz")
    assert not cell.finished()
    assert run_experiment(cfg, out, console=quiet) == 0
    assert cell.finished()
    reloaded = Estimate.load(cell.dir / "estimate.npz")
    assert np.isfinite(reloaded.poses).all()
    truth = reference_of(datasets.load("sim:landmarks", n_landmarks=8, laps=1, seed=0))
    assert pd.read_csv(out / "summary.csv").at[0, "ate.rmse"] == pytest.approx(ate(reloaded, truth)[0]["rmse"])
    # metric settings changed: the estimate is reused only if it is the file estimate.json recorded
    estimate.save(cell.dir / "estimate.npz")  # the NaN pose again
    changed = _config(tmp_path, TINY.replace("seeds: 2", "seeds: 1").replace("[ate, cost]", "{ate: {align: none}}"))
    assert run_experiment(changed, out, console=quiet) == 0
    assert np.isfinite(Estimate.load(cell.dir / "estimate.npz").poses).all()


class _InProcessWorker:
    """The cells run in this process (so that a monkeypatched writer reaches them)."""

    def __init__(self, env):
        pass

    def run(self, spec, timeout):
        from slamarena.experiments.cell import _prepare, outcome, record

        _prepare(spec)
        return outcome(spec.id, spec.dir, record(spec), 0.0)

    def close(self):
        pass


def _disk_full(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_is_one_line_leaves_no_temporary_and_the_run_resumes(tmp_path, monkeypatch):
    import slamarena.datasets.estimate as estimate_module
    from slamarena.experiments import cell as cell_module
    from slamarena.experiments.cli_run import run_from_cli

    path = tmp_path / "exp.yaml"
    path.write_text(TINY.replace("seeds: 2", "seeds: 3"))
    out = tmp_path / "out"
    monkeypatch.setattr(cell_module, "Worker", _InProcessWorker)
    cfg = load_config(path)
    assert run_experiment(cfg, out, console=Console(file=io.StringIO())) == 0  # three finished cells to size from
    real_savez = np.savez_compressed

    def half_written(fh, **arrays):  # the estimate's temporary gets some bytes, then the disk is full
        fh.write(b"PK\x03\x04 partial")
        _disk_full()

    monkeypatch.setattr(estimate_module.np, "savez_compressed", half_written)
    console, buffer = _log_console()
    monkeypatch.setattr("rich.console.Console", lambda *a, **k: console)
    code = run_from_cli(config=path, jobs=1, scheduler=None, out=out, force=True, dry_run=False)
    assert code == 1
    [message] = [line for line in buffer.getvalue().splitlines() if "disk full" in line]
    assert str(out) in message and "MB free" in message and "cells left need about" in message
    assert "Traceback" not in buffer.getvalue()
    assert not _temporaries(out)
    # the tables at the end of a run cannot be written either: the same one line, no temporary
    monkeypatch.setattr(estimate_module.np, "savez_compressed", real_savez)
    monkeypatch.setattr("slamarena.experiments.results.os.fsync", _disk_full)
    console, buffer = _log_console()
    assert run_from_cli(config=path, jobs=1, scheduler=None, out=out, force=False, dry_run=False) == 1
    assert "disk full" in buffer.getvalue() and "Traceback" not in buffer.getvalue()
    assert not _temporaries(out)
    monkeypatch.undo()
    assert run_experiment(cfg, out, console=Console(file=io.StringIO())) == 0
    assert (pd.read_csv(out / "summary.csv")["status"] == "ok").all()
    assert not _temporaries(out)


def test_a_cell_that_finds_the_disk_full_removes_its_temporaries(tmp_path, monkeypatch):
    from slamarena.experiments import results
    from slamarena.experiments.cell import EXIT_DISK_FULL, _prepare, record
    from slamarena.experiments.plan import cell_env, cell_spec

    cfg = _config(tmp_path, TINY.replace("seeds: 2", "seeds: 1"))
    [cell] = plan(cfg, tmp_path / "out")
    real_fsync = results.os.fsync
    calls = []

    def fsync_then_full(fd):  # the first files fit, series.npz does not (its temporary is written, then ENOSPC)
        calls.append(fd)
        if len(calls) > 2:
            _disk_full()
        real_fsync(fd)

    monkeypatch.setattr(results.os, "fsync", fsync_then_full)
    spec = cell_spec(cfg, cell, cell_env(cfg))
    _prepare(spec)
    assert record(spec) == EXIT_DISK_FULL
    assert not _temporaries(cell.dir) and not (cell.dir / "metrics.json").exists()
    assert not cell.finished()
