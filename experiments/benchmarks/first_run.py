"""``slamarena bench first-run``: the default comparison as a new user runs it, cold and then warm, against the goals.

Two runs of ``slamarena run -j 2`` (the default config, 70 cells), each into a fresh results directory, both with
``NUMBA_CACHE_DIR`` set to one fresh directory: the first (cold) compiles every numba kernel, the second (warm) loads
them from that cache — what a user's first and second run cost. For each: wall time and CPU time (user + system of
the run and every process under it, from ``getrusage(RUSAGE_CHILDREN)``), the ratio of the wall time to its goal
(cold ≤ 180 s, warm ≤ 90 s on two idle cores) with a met / not met verdict, the load average before and after (the
goals are for an idle machine: on a loaded one the CPU time is the figure to compare), and whether both runs
gave the same summary numbers. ``--quick``: ``--seeds 1`` (14 cells), where the goals are not measurable. With
``--out DIR`` the two results directories are kept (``DIR/first_run-XXXX/cold`` and ``…/warm``, a fresh directory
each time) to compare their ``summary.csv`` with another revision's.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from slamarena.experiments.benchmarks import aim, write_rows

#: the staged data it reads (``slamarena bench list``): none, the default run is simulators and the GTSAM wheel's data
STAGED_DATA: dict[str, bool] = {}

#: wall-time goals of the default run on two idle cores [s]
GOALS = {"cold": 180.0, "warm": 90.0}
JOBS = 2
CLI = [sys.executable, "-c", "from slamarena.experiments.cli import main; main()"]


def timed_run(out: Path, numba_cache: Path, seeds: int | None) -> dict:
    """One ``slamarena run -j 2`` into ``out``: exit code, wall and CPU seconds, load averages around it."""
    command = [*CLI, "run", "-j", str(JOBS), "--out", str(out), *(["--seeds", str(seeds)] if seeds else [])]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(numba_cache)}
    load_before = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    tic = time.perf_counter()
    done = subprocess.run(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - tic
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {
        "code": done.returncode,
        "stderr_tail": "\n".join(done.stderr.strip().splitlines()[-5:]) if done.returncode else "",
        "wall_s": wall,
        "cpu_s": cpu,
        "load_before": load_before,
        "load_after": os.getloadavg()[0],
        "command": " ".join(command[3:]),
    }


def same_numbers(a: Path, b: Path) -> bool:
    """Whether two runs' summaries agree on every accuracy and consistency column (cost columns are timings)."""
    import pandas as pd

    frames = [pd.read_csv(p / "summary.csv").sort_values(["dataset", "estimator", "seed"]) for p in (a, b)]
    columns = [c for c in frames[0].columns if c.split(".")[0] in ("ate", "rpe", "nees", "nis", "map")]
    return all(frames[0][c].reset_index(drop=True).equals(frames[1][c].reset_index(drop=True)) for c in columns)


def main(out: Path | None = None, quick: bool = False) -> int:
    seeds = 1 if quick else None
    with tempfile.TemporaryDirectory(prefix="slamarena-first-run-") as scratch:
        numba_cache = Path(scratch) / "numba-cache"  # fresh: the first run is cold
        if out is not None:  # the two runs are kept, in a fresh directory
            Path(out).mkdir(parents=True, exist_ok=True)
            scratch = tempfile.mkdtemp(prefix="first_run-", dir=out)
            print(f"results directories kept in {scratch}/cold and {scratch}/warm")
        scratch = Path(scratch)
        rows = []
        for phase in ("cold", "warm"):
            result = timed_run(scratch / phase, numba_cache, seeds)
            goal = GOALS[phase]
            target = f"<= {goal:.0f} s wall on {JOBS} idle cores"
            if result["code"] != 0:
                verdict = f"not measured: the run failed (exit {result['code']}): {result['stderr_tail']}"
            elif quick:
                verdict = aim(target, None, "--quick runs 14 of the 70 cells")
            else:
                verdict = f"{result['wall_s'] / goal:.2f} x the goal " + aim(target, result["wall_s"] <= goal)
            rows.append({"phase": phase, "goal_s": goal, **result, "verdict": verdict})
            print(
                f"{phase}: wall {result['wall_s']:.1f} s, CPU {result['cpu_s']:.1f} s (CPU/wall {result['cpu_s'] / result['wall_s']:.2f}); "
                f"{verdict}; "
                f"load average {result['load_before']:.1f} before, {result['load_after']:.1f} after"
            )
        if all(r["code"] == 0 for r in rows):
            agree = same_numbers(scratch / "cold", scratch / "warm")
            print(f"cold and warm runs give the same accuracy and consistency numbers: {'yes' if agree else 'NO'}")
        print(f"command: slamarena run -j {JOBS}{' --seeds 1' if quick else ''} (NUMBA_CACHE_DIR fresh for cold)")
    write_rows(rows, out, "first_run.csv")
    return 0 if all(r["code"] == 0 for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main(quick="--quick" in sys.argv))
