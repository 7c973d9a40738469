"""Interrupted and damaged runs: SIGKILL takes the cells along, Ctrl-C says how to resume, damaged caches are recomputed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from slamarena.experiments.config import load_config
from slamarena.experiments.plan import plan
from slamarena.experiments.runner import run_experiment

SLOW = """
name: slow
seeds: 2
timeout: 300
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 40, laps: 3}
estimators:
  - name: ekf_slam
metrics: [ate]
figures: []
"""
CLI = [sys.executable, "-c", "from slamarena.experiments.cli import main; main()"]


def _cell_processes(parent: int | None = None) -> list[int]:
    """PIDs of running experiment-cell processes (of ``parent``, or any)."""
    out = subprocess.run(
        ["pgrep", *(["-P", str(parent)] if parent else []), "-f", "slamarena.experiments.cell"],
        capture_output=True,
        text=True,
    )
    return [int(p) for p in out.stdout.split()]


def _start(tmp_path, text=SLOW):
    path = tmp_path / "slow.yaml"
    path.write_text(textwrap.dedent(text))
    out = tmp_path / "out"
    # SIGINT at its default in the child, as under a terminal: a shell starts background jobs with it ignored, and an
    # ignored SIGINT is inherited through exec (Python then installs no KeyboardInterrupt handler)
    proc = subprocess.Popen(
        [*CLI, "run", str(path), "--out", str(out), "-j", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not _cell_processes(proc.pid):
        time.sleep(0.05)
    assert _cell_processes(proc.pid), "no cell process started"
    return proc, path, out


def test_sigkill_of_the_runner_takes_its_cells_along_and_leaves_no_spec_files(tmp_path):
    proc, _, out = _start(tmp_path)
    cells = set(_cell_processes(proc.pid))
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and cells & set(_cell_processes()):
        time.sleep(0.05)
    assert not cells & set(_cell_processes()), "a cell process outlived the killed runner"
    assert not list(out.rglob(".spec*")) and not list(out.rglob("*.tmp"))


def test_ctrl_c_records_the_interruption_and_says_how_to_resume(tmp_path):
    proc, path, out = _start(tmp_path)
    cells = set(_cell_processes(proc.pid))
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "resume" in err and str(path) in err.replace("\n", "")
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["finished"] is None
    assert manifest["interrupted"]["total_cells"] == 2 and manifest["interrupted"]["finished_cells"] < 2
    assert not cells & set(_cell_processes()), "a cell process outlived the interrupted run"


@pytest.mark.parametrize("damaged", ["series.npz", "estimate.npz"])
def test_a_damaged_cached_file_is_recomputed_not_reused(tmp_path, damaged):
    path = tmp_path / "tiny.yaml"
    path.write_text(
        SLOW.replace("n_landmarks: 40, laps: 3", "n_landmarks: 8, laps: 1")
        .replace("seeds: 2", "seeds: 1")
        .replace("ekf_slam", "dead_reckoning")
    )
    cfg = load_config(path)
    out = tmp_path / "out"
    quiet = __import__("rich.console", fromlist=["Console"]).Console(file=open(os.devnull, "w"))
    assert run_experiment(cfg, out, console=quiet) == 0
    [cell] = plan(cfg, out)
    first = json.loads((cell.dir / "metrics.json").read_text())
    target = cell.dir / damaged
    target.write_bytes(target.read_bytes()[: target.stat().st_size // 2])  # truncated: its key still matches
    assert not cell.finished()
    assert run_experiment(cfg, out, console=quiet) == 0
    assert cell.finished()
    again = json.loads((cell.dir / "metrics.json").read_text())
    assert again["pid"] != first["pid"] and again["metrics"]["ate"] == first["metrics"]["ate"]
