"""One cell of an experiment (dataset × method × seed), run in a fresh process of its own.

``run_cell(spec, timeout)`` — called by the runner's local thread pool or on a Dask worker —
starts ``python -m slamarena.experiments.cell`` with the spec as JSON on its standard input and
waits for it, killing it at the timeout. A fresh process per cell isolates crashes of native
libraries, makes the timeout a hard one (the process is killed) and makes ``ru_maxrss`` the
peak memory of this cell alone. On Linux the cell process is bound to the thread that started
it (``PR_SET_PDEATHSIG``): if the runner dies, even by SIGKILL, its cells die with it.
:func:`terminate_all` kills the cells still running (the runner calls it on Ctrl-C).

In the child (:func:`main`): load the dataset (a simulator gets the cell's seed as ``seed``;
a real dataset is loaded as is), construct the method from the registry (``seed`` passed only
if its parameters take one), run it and time the run, then compute the metrics and write
the cell's files (see :mod:`slamarena.experiments.results`) — ``metrics.json`` last. If
``estimate.npz`` already holds this cell's key (only the metric settings changed) and reads
back whole, the estimate is reused and only the metrics are recomputed (unless the spec says
``force``); a damaged one is recomputed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
import traceback
from datetime import UTC, datetime
from pathlib import Path

__all__ = ["run_cell", "terminate_all", "main"]

_LIVE: set[subprocess.Popen] = set()
_LIVE_LOCK = threading.Lock()


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _die_with_parent() -> None:  # pragma: no cover - runs in the child between fork and exec
    import ctypes

    PR_SET_PDEATHSIG = 1
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def terminate_all() -> int:
    """Kill every cell process still running; returns how many there were."""
    with _LIVE_LOCK:
        live = list(_LIVE)
    for proc in live:
        proc.kill()
    return len(live)


def run_cell(spec: dict, timeout: float | None) -> dict:
    """Run one cell in a child process; returns ``{"id", "status", "error", "traceback", "elapsed"}``."""
    cell = Path(spec["dir"])
    cell.mkdir(parents=True, exist_ok=True)
    (cell / "error.json").unlink(missing_ok=True)
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "slamarena.experiments.cell"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **spec.get("env", {})},
        preexec_fn=_die_with_parent if sys.platform == "linux" else None,
    )
    with _LIVE_LOCK:
        _LIVE.add(proc)
    try:
        try:
            _, stderr = proc.communicate(json.dumps(spec), timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            return {
                "id": spec["id"],
                "status": "timeout",
                "error": f"timed out after {timeout:g} s (killed)",
                "traceback": "",
                "elapsed": time.perf_counter() - start,
            }
    finally:
        with _LIVE_LOCK:
            _LIVE.discard(proc)
    elapsed = time.perf_counter() - start
    if proc.returncode == 0:
        return {"id": spec["id"], "status": "ok", "error": "", "traceback": "", "elapsed": elapsed}
    error_file = cell / "error.json"
    if error_file.exists():
        info = json.loads(error_file.read_text())
        return {
            "id": spec["id"],
            "status": "error",
            "error": info["error"],
            "traceback": info["traceback"],
            "elapsed": elapsed,
        }
    if proc.returncode < 0:
        name = signal.Signals(-proc.returncode).name
        return {
            "id": spec["id"],
            "status": "killed",
            "error": f"cell process killed by {name}",
            "traceback": "",
            "elapsed": elapsed,
        }
    tail = (stderr or "").strip().splitlines()[-20:]
    return {
        "id": spec["id"],
        "status": "error",
        "error": f"cell process exited with code {proc.returncode}",
        "traceback": "\n".join(tail),
        "elapsed": elapsed,
    }


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


def execute(spec: dict) -> dict:
    """The work of one cell (in the child process); returns the ``metrics.json`` content."""

    from slamarena import datasets
    from slamarena.datasets.estimate import Estimate
    from slamarena.targets import import_target

    from .config import method_table
    from .metrics import METRICS, CellData, evaluate, reference_of
    from .metrics.cost import peak_rss_mb
    from .results import read_json, save_npz, write_json, write_trajectory_tum

    started = _now()
    cell = Path(spec["dir"])
    ds, es, seed = spec["dataset"], spec["estimator"], spec["seed"]
    t0 = time.perf_counter()
    params = dict(ds["params"], seed=seed) if ds["simulator"] else dict(ds["params"])
    data = datasets.load(ds["name"], **params)
    load_time = time.perf_counter() - t0

    estimate_file = cell / "estimate.npz"
    previous = cell / "estimate.json"
    estimate = None
    if (
        not spec.get("force")
        and estimate_file.exists()
        and previous.exists()
        and read_json(previous).get("key") == spec["key"]
    ):
        try:
            estimate, wall = Estimate.load(estimate_file), read_json(previous)["wall"]
        except Exception:  # a damaged cached estimate (its key matches, its bytes do not): compute it again
            estimate = None
    if estimate is None:
        cls = import_target(method_table()[es["name"]])
        kwargs = dict(es["params"])
        if spec["seed_to_estimator"]:  # the method's parameters take a seed (EstimatorSpec.takes_seed)
            kwargs["seed"] = seed
        method = cls(**kwargs)
        t1 = time.perf_counter()
        estimate = method.run(data)
        wall = time.perf_counter() - t1
        estimate.save(estimate_file)
        write_trajectory_tum(cell / "trajectory.tum", estimate.t, estimate.poses, data)
        if spec.get("mcap"):
            from .mcap_output import MCAP_NAME, write_result_mcap

            write_result_mcap(cell / MCAP_NAME, estimate, method)
        write_json(previous, {"key": spec["key"], "wall": wall, "finished": _now()})

    ref = reference_of(data)
    if ref.t is not None:  # beside trajectory.tum, same stamps convention: `evo_ape tum groundtruth.tum trajectory.tum`
        write_trajectory_tum(cell / "groundtruth.tum", ref.t, ref.poses, data)
    selected = {name: METRICS[name].params(**p) for name, p in spec["metrics"].items()}
    cell_data = CellData(estimate, data, ref, wall=wall, peak_rss=peak_rss_mb())
    scalars, series, skipped = evaluate(cell_data, selected)
    save_npz(cell / "series.npz", _flatten_series(series))
    save_npz(cell / "truth.npz", _truth_arrays(ref))
    alignment = series.get("ate", {}).get("alignment")
    result = {
        "status": "ok",
        "id": spec["id"],
        "key": spec["key"],
        "metrics_key": spec["metrics_key"],
        "dataset": ds,
        "estimator": es,
        "seed": seed,
        "metrics": scalars,
        "skipped": skipped,
        "alignment": None if alignment is None else alignment.as_dict(),
        "wall": wall,
        "load_time": load_time,
        "peak_rss_mb": peak_rss_mb(),
        "started": started,
        "finished": _now(),
        "pid": os.getpid(),
    }
    write_json(cell / "metrics.json", result)
    return result


def main(argv: list[str] | None = None) -> int:
    """The cell process: the spec is JSON on standard input (or in the file named by the one argument)."""
    from .results import write_json

    argv = sys.argv[1:] if argv is None else argv
    spec = json.loads(Path(argv[0]).read_text() if argv else sys.stdin.read())
    try:
        execute(spec)
    except Exception as exc:
        write_json(
            Path(spec["dir"]) / "error.json",
            {
                "status": "error",
                "error": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(),
                "finished": _now(),
            },
        )
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
