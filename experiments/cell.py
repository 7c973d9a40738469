"""One cell of an experiment (dataset × method × seed), run in a process of its own.

Two ways to start that process, with the same guarantees (a hard timeout that kills it, ``peak_rss_mb`` of the cell
alone, a crash of a native library confined to it, and no cell outliving the runner):

- :class:`Worker` — the local runner's way: one long-lived ``python -m slamarena.experiments.cell --serve`` process
  per job slot imports the packages every cell needs once (numpy, scipy, GTSAM, numba, every method's module:
  :func:`preload`, ~2 s of CPU a fresh interpreter pays again for each cell) and then forks a child per cell
  (:func:`serve`). The child runs the cell; the worker waits for it, kills it at the timeout and answers one JSON line
  per cell. numba kernels compiled by a cell are in numba's on-disk cache (``cache=True``); the worker loads them
  from there before it forks the next cell (:func:`~slamarena.experiments.compilation.load_cached_kernels`), so that
  the cells after it start with them.
- :func:`run_cell` — on a Dask worker: a fresh ``python -m slamarena.experiments.cell`` process per cell, the spec as
  JSON on its standard input.

On Linux every such process is bound to the thread that started it (``PR_SET_PDEATHSIG``): if the runner dies, even
by SIGKILL, its workers die, and their cells with them. :func:`terminate_all` kills the processes still running
(the runner calls it on Ctrl-C).

In the cell (:func:`record`, :func:`execute`): load the dataset (a simulator gets the cell's seed as ``seed``; a real
dataset is loaded as is), construct the method from the registry (``seed`` passed only if its parameters take one),
run it and time the run, then compute the metrics and write the cell's files (see :mod:`slamarena.experiments.results`)
— ``metrics.json`` last, with the SHA-256 of ``estimate.npz`` and ``series.npz`` it was computed from (the runner
reuses a cell only if its files still have those digests). If ``estimate.npz`` already holds this cell's key (only the
metric settings changed) and has the digest ``estimate.json`` recorded, the estimate is reused and only the metrics
are recomputed (unless the spec says ``force``); a damaged or edited one is recomputed. The seconds numba spent
compiling are measured (:class:`~slamarena.experiments.compilation.CompileClock`), written to ``metrics.json`` as
``compile_s``, and named in the message of a cell that times out. A full disk ends the cell with
:data:`EXIT_DISK_FULL`, its temporaries removed.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import struct
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import asdict, replace
from datetime import UTC, datetime
from pathlib import Path

from .cellspec import CellOutcome, CellSpec

__all__ = [
    "run_cell",
    "Worker",
    "terminate_all",
    "record",
    "execute",
    "serve",
    "preload",
    "main",
    "file_digest",
    "EXIT_DISK_FULL",
    "DISK_FULL_ERRNOS",
]

#: exit code of a cell that could not write its files because the disk (or the user's quota) is full
EXIT_DISK_FULL = 28
#: ``OSError.errno`` values that mean "no space to write": a full device, an exhausted quota
DISK_FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT)

_LIVE: set[subprocess.Popen] = set()
_LIVE_LOCK = threading.Lock()


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _die_with_parent() -> None:  # pragma: no cover - runs in the child between fork and exec (or fork and the cell)
    import ctypes

    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def terminate_all() -> int:
    """Kill every cell process and worker still running; returns how many there were."""
    with _LIVE_LOCK:
        live = list(_LIVE)
    for proc in live:
        proc.kill()
    return len(live)


def _start(args: list[str], env: dict, stderr) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-m", "slamarena.experiments.cell", *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=stderr,
        text=True,
        env={**os.environ, **env},
        preexec_fn=_die_with_parent if sys.platform == "linux" else None,
    )
    with _LIVE_LOCK:
        _LIVE.add(proc)
    return proc


def _forget(proc: subprocess.Popen) -> None:
    with _LIVE_LOCK:
        _LIVE.discard(proc)


def file_digest(path: Path) -> str | None:
    """SHA-256 of a file (``None`` if it cannot be read): what ``metrics.json`` and ``estimate.json`` record of the
    files they were computed from, so that an edited or damaged file is recomputed, never reused."""
    from .results import sha256_file

    try:
        return sha256_file(path)
    except OSError:
        return None


def outcome(
    cell_id: str,
    cell_dir: str | Path,
    returncode: int | None,
    elapsed: float,
    stderr: str = "",
    timeout: float | None = None,
    compile_s: float = 0.0,
) -> CellOutcome:
    """What became of the process of cell ``cell_id`` writing into ``cell_dir`` (``returncode`` None: killed at the
    timeout): ok, error (with the error and traceback its ``error.json`` records, else the tail of its output), timeout,
    killed or disk_full."""
    ended = CellOutcome(cell_id, elapsed=elapsed, compile_s=compile_s)
    if returncode is None:
        compiled = f"; {compile_s:.0f} s of it compiling numba kernels" if compile_s >= 0.5 else ""
        return replace(ended, status="timeout", error=f"timed out after {timeout:g} s (killed){compiled}")
    if returncode == 0:
        return ended
    if returncode == EXIT_DISK_FULL:
        return replace(ended, status="disk_full", error=f"no space left on the device writing {cell_dir}")
    try:
        info = json.loads((Path(cell_dir) / "error.json").read_text())
        return replace(ended, status="error", error=info["error"], traceback=info["traceback"])
    except (OSError, ValueError, KeyError):
        pass
    if returncode < 0:
        return replace(ended, status="killed", error=f"cell process killed by {signal.Signals(-returncode).name}")
    tail = (stderr or "").strip().splitlines()[-20:]
    return replace(
        ended, status="error", error=f"cell process exited with code {returncode}", traceback="\n".join(tail)
    )


def _prepare(spec: CellSpec) -> None:
    cell = Path(spec.dir)
    cell.mkdir(parents=True, exist_ok=True)
    (cell / "error.json").unlink(missing_ok=True)


def run_cell(spec: CellSpec, timeout: float | None) -> CellOutcome:
    """Run one cell in a fresh child process (the Dask path); returns its :func:`outcome`."""
    _prepare(spec)
    start = time.perf_counter()
    proc = _start([], spec.env, subprocess.PIPE)
    try:
        try:
            _, stderr = proc.communicate(json.dumps(spec.to_dict()), timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            return outcome(spec.id, spec.dir, None, time.perf_counter() - start, timeout=timeout)
    finally:
        _forget(proc)
    return outcome(spec.id, spec.dir, proc.returncode, time.perf_counter() - start, stderr)


class Worker:
    """A job slot's long-lived cell server (``python -m slamarena.experiments.cell --serve``, :func:`serve`), started
    on first use and again after it died. Use it from one thread: that thread is the server's parent for
    ``PR_SET_PDEATHSIG``."""

    def __init__(self, env: dict):
        self.env = env
        self.proc: subprocess.Popen | None = None

    def run(self, spec: CellSpec, timeout: float | None) -> CellOutcome:
        """Run one cell in a child the server forks; returns its :func:`outcome`."""
        if self.proc is None or self.proc.poll() is not None:
            self.proc = _start(["--serve"], self.env, subprocess.DEVNULL)
        start = time.perf_counter()
        try:
            self.proc.stdin.write(json.dumps({"spec": spec.to_dict(), "timeout": timeout}) + "\n")
            self.proc.stdin.flush()
            line = self.proc.stdout.readline()
        except OSError:
            line = ""
        if line:
            return CellOutcome.from_dict(json.loads(line))
        code = self.proc.wait()  # the server died (killed from outside, out of memory), the cell with it
        _forget(self.proc)
        self.proc = None
        return outcome(spec.id, spec.dir, code if code < 0 else -signal.SIGKILL, time.perf_counter() - start)

    def close(self) -> None:
        """Let the server exit (end of its input), or kill it if it does not."""
        if self.proc is None:
            return
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        _forget(self.proc)
        self.proc = None


def preload() -> None:
    """Import what cells import — numba, the simulators, every method's module (GTSAM, filterpy …), the metrics —
    so that a cell forked from this process starts with them loaded. A module that fails to import is left out here:
    the cell that needs it reports the error."""
    import numba  # noqa: F401

    from slamarena.datasets.registry import SIMULATORS
    from slamarena.targets import import_target

    from .compilation import CompileClock  # noqa: F401
    from .config import method_table
    from .metrics import METRICS  # noqa: F401
    from .results import write_json  # noqa: F401

    for target in (*SIMULATORS.values(), *method_table().values()):
        try:
            import_target(target)
        except Exception:  # noqa: BLE001 - reported by the cell that uses it
            continue


def serve() -> int:
    """The worker process: :func:`preload`, then for each request line ``{"spec", "timeout"}`` on standard input fork a
    child that runs the cell (:func:`record`), wait for it (killing it at the timeout) and answer its :func:`outcome`
    as one JSON line on standard output. The child's own output goes to a temporary file (the tail of a crash's
    message is kept in the outcome); its numba compile seconds to a shared page, readable even after a kill."""
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)  # whatever prints to standard output from now on cannot garble the answers
    preload()
    for line in sys.stdin:
        request = json.loads(line)
        _load_kernels()
        ended = _fork_cell(CellSpec.from_dict(request["spec"]), request["timeout"])
        answers.write(json.dumps(ended.to_dict()) + "\n")
        answers.flush()
    return 0


def _load_kernels() -> None:
    """Load the kernels numba's cache holds (earlier cells compiled them) into the worker, so that the cell forked next
    starts with them (:func:`~slamarena.experiments.compilation.load_cached_kernels`); a cache entry it cannot read is
    left to the cell, which compiles or loads what it needs itself."""
    from .compilation import load_cached_kernels

    try:
        load_cached_kernels()
    except Exception:  # noqa: BLE001 - the cell loads or compiles its kernels itself
        pass


def _fork_cell(spec: CellSpec, timeout: float | None) -> CellOutcome:
    import mmap
    import select
    import tempfile

    _prepare(spec)
    shared = mmap.mmap(-1, 8)  # the child's compile seconds (a double), shared across the fork
    log = tempfile.TemporaryFile()
    parent = os.getpid()
    start = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the cell's own process
        code = 1
        try:
            if sys.platform == "linux":
                _die_with_parent()
            if os.getppid() != parent:  # the worker died before the line above took effect
                os._exit(1)
            os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
            os.dup2(log.fileno(), 1)
            os.dup2(log.fileno(), 2)
            code = record(spec, on_compile=lambda seconds: shared.__setitem__(slice(0, 8), struct.pack("d", seconds)))
        except KeyboardInterrupt:
            code = 130
        except BaseException:
            traceback.print_exc()
        finally:
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except Exception:  # noqa: BLE001 - exiting regardless
                    pass
            os._exit(code)
    pidfd = os.pidfd_open(pid)
    try:
        ended, _, _ = select.select([pidfd], [], [], timeout)
        if not ended:
            os.kill(pid, signal.SIGKILL)
        _, status, _ = os.wait4(pid, 0)
    finally:
        os.close(pidfd)
    elapsed = time.perf_counter() - start
    (compile_s,) = struct.unpack("d", shared[:8])
    log.seek(0)
    stderr = log.read().decode("utf-8", errors="replace")
    log.close()
    shared.close()
    code = os.waitstatus_to_exitcode(status) if ended else None
    return outcome(spec.id, spec.dir, code, elapsed, stderr, timeout, compile_s)


def _flatten_series(series: dict) -> dict:
    import numpy as np

    from .metrics.series import series_key

    out = {}
    for metric, values in series.items():
        for key, value in values.items():
            if isinstance(value, np.ndarray):
                out[series_key(metric, key)] = value
    return out


def _truth_arrays(ref) -> dict:
    out = {}
    if ref.t is not None:
        out.update(t=ref.t, poses=ref.poses)
    if ref.landmarks is not None:
        out.update(landmark_ids=ref.landmark_ids, landmarks=ref.landmarks)
    return out


def execute(spec: CellSpec, clock=None) -> dict:
    """The work of one cell (in its own process); returns the ``metrics.json`` content. ``clock`` is the
    :class:`~slamarena.experiments.compilation.CompileClock` running around it (its seconds go to ``compile_s``)."""

    from slamarena import datasets
    from slamarena.datasets.estimate import Estimate
    from slamarena.targets import import_target

    from .config import method_table
    from .metrics import METRICS, CellData, evaluate, reference_of
    from .metrics.cost import peak_rss_mb
    from .results import read_json, save_npz, write_json, write_trajectory_tum

    started = _now()
    cell = Path(spec.dir)
    ds, es, seed = spec.dataset, spec.estimator, spec.seed
    t0 = time.perf_counter()
    params = dict(ds.params, seed=seed) if ds.simulator else dict(ds.params)
    data = datasets.load(ds.name, **params)
    if ds.landmarks is not None:  # the config's extraction: the scans' landmarks become the range-bearing stream
        from slamarena.mapping.landmark_extraction import ExtractionParams, landmark_sequence

        data = landmark_sequence(data, ExtractionParams.of(ds.landmarks))
    load_time = time.perf_counter() - t0

    estimate_file = cell / "estimate.npz"
    previous = cell / "estimate.json"
    estimate = None
    if not spec.force and previous.exists():
        stamp = read_json(previous)
        if stamp.get("key") == spec.key and stamp.get("sha256") and stamp["sha256"] == file_digest(estimate_file):
            estimate, wall = Estimate.load(estimate_file), stamp["wall"]
    if estimate is None:
        cls = import_target(method_table()[es.name])
        kwargs = dict(es.params)
        if spec.seed_to_estimator:  # the method's parameters take a seed (EstimatorSpec.takes_seed)
            kwargs["seed"] = seed
        method = cls(**kwargs)
        t1 = time.perf_counter()
        estimate = method.run(data)
        wall = time.perf_counter() - t1
        estimate.save(estimate_file)
        write_trajectory_tum(cell / "trajectory.tum", estimate.t, estimate.poses, data)
        if spec.mcap:
            from .mcap_output import MCAP_NAME, write_result_mcap

            write_result_mcap(cell / MCAP_NAME, estimate, method)
        write_json(previous, {"key": spec.key, "wall": wall, "finished": _now(), "sha256": file_digest(estimate_file)})

    ref = reference_of(data)
    if ref.t is not None:  # beside trajectory.tum, same stamps convention: `evo_ape tum groundtruth.tum trajectory.tum`
        write_trajectory_tum(cell / "groundtruth.tum", ref.t, ref.poses, data)
    selected = {name: METRICS[name].params(**p) for name, p in spec.metrics.items()}
    cell_data = CellData(estimate, data, ref, wall=wall, peak_rss=peak_rss_mb())
    scalars, series, skipped = evaluate(cell_data, selected)
    save_npz(cell / "series.npz", _flatten_series(series))
    save_npz(cell / "truth.npz", _truth_arrays(ref))
    alignment = series.get("ate", {}).get("alignment")
    result = {
        "status": "ok",
        "id": spec.id,
        "key": spec.key,
        "metrics_key": spec.metrics_key,
        "dataset": asdict(ds),
        "estimator": asdict(es),
        "seed": seed,
        "metrics": scalars,
        "skipped": skipped,
        "alignment": None if alignment is None else alignment.as_dict(),
        "wall": wall,
        "load_time": load_time,
        "compile_s": None if clock is None else clock.seconds,
        "peak_rss_mb": peak_rss_mb(),
        "files": {name: file_digest(cell / name) for name in CACHED_FILES},
        "started": started,
        "finished": _now(),
        "pid": os.getpid(),
    }
    write_json(cell / "metrics.json", result)
    return result


#: the files of a finished cell whose SHA-256 ``metrics.json`` records (its numbers were computed from them)
CACHED_FILES = ("estimate.npz", "series.npz")


def remove_temporaries(directory: Path) -> None:
    """Delete the ``*.tmp`` files a write cut short left in ``directory`` (the cell's own directory)."""
    for path in Path(directory).glob("*.tmp"):
        path.unlink(missing_ok=True)


def record(spec: CellSpec, on_compile: Callable[[float], None] | None = None) -> int:
    """Run the cell and record its outcome in its directory: 0 (``metrics.json`` written), 1 (``error.json`` with the
    error and traceback), :data:`EXIT_DISK_FULL` (no space to write; temporaries removed, nothing half-written)."""
    from .compilation import CompileClock
    from .results import write_json

    cell = Path(spec.dir)
    try:
        try:
            with CompileClock(on_compile) as clock:
                execute(spec, clock)
            return 0
        except Exception as exc:
            if isinstance(exc, OSError) and exc.errno in DISK_FULL_ERRNOS:
                raise
            error = {
                "status": "error",
                "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(),
                "finished": _now(),
            }
            write_json(cell / "error.json", error)
            return 1
    except OSError as exc:
        if exc.errno not in DISK_FULL_ERRNOS:
            raise
        remove_temporaries(cell)
        print(f"no space left on the device writing {cell}", file=sys.stderr)
        return EXIT_DISK_FULL


def main(argv: list[str] | None = None) -> int:
    """The cell process: ``--serve`` (a worker, :func:`serve`), or one cell whose spec is JSON on standard input (or
    in the file named by the one argument)."""
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["--serve"]:
        return serve()
    spec = json.loads(Path(argv[0]).read_text() if argv else sys.stdin.read())
    return record(CellSpec.from_dict(spec))


if __name__ == "__main__":
    raise SystemExit(main())
