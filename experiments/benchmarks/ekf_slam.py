"""``slamarena bench ekf-slam``: EKF-SLAM cost per step against the map size.

For n = 25 … 1600 landmarks (N = 3 + 2n), a filter holding n mapped landmarks does steps of
one prediction plus an update with 10 observations of known landmarks. Reported, all from
the same run: the least CPU time (``time.process_time``, all threads; the minimum over repeats
is the estimate least disturbed by other processes on a shared machine) per step of the efficient filter (sequential and batched
updates), of the literal dense reference (``slamarena.estimators.ekf_slam.reference``; up to n = 800,
since it costs O(N³) per observation), their ratio, and the log-log slope of the efficient
filter's time over n ∈ [200, 1600] (the O(n²) claim: aim ≤ 2.2; at n = 800 the aim is ≥ 50×
the reference).

Both filters are timed single-threaded (the measurement runs in a child process started with
``OPENBLAS_NUM_THREADS=1`` etc.), so the ratio compares algorithms, not thread counts, and
idle BLAS threads spinning on a busy machine do not pollute the CPU times.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.reference import ReferenceEKFSLAM
from slamarena.estimators.models import observe
from slamarena.experiments.benchmarks import loglog_slope, measure_single_threaded, write_rows

OBSERVATIONS = 10
R = np.diag([0.1**2, np.radians(1.0) ** 2])
M = np.diag([0.1**2, 0.05**2])


def _mapped_filter(n: int, rng: np.random.Generator, update: str) -> tuple[EKFSLAM, np.ndarray]:
    """A filter that has already mapped n landmarks scattered around the robot."""
    radius = 5.0 + rng.uniform(0, 45.0, n)
    angle = rng.uniform(-np.pi, np.pi, n)
    L = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    ekf = EKFSLAM(update=update, twist_cov=M, range_bearing_cov=R, initial_cov=[0.01, 0.01, 0.001], capacity=3 + 2 * n)
    z = observe(np.zeros(3), L) + rng.normal(size=(n, 2)) * np.sqrt(np.diag(R))
    for k in range(0, n, 50):
        ekf.update(np.column_stack([z[k:k + 50], np.arange(k, min(k + 50, n))]))
    return ekf, L


def _observations(rng, L, pose) -> np.ndarray:
    ids = rng.choice(L.shape[0], OBSERVATIONS, replace=False)
    z = observe(pose, L[ids]) + rng.normal(size=(OBSERVATIONS, 2)) * np.sqrt(np.diag(R))
    return np.column_stack([z, ids])


def _time_steps(step, repeats: int) -> float:
    """Least CPU time of one step over the repeats (robust to other processes on a shared machine)."""
    times = []
    for _ in range(repeats):
        t = time.process_time()
        step()
        times.append(time.process_time() - t)
    return float(np.min(times))


def measure(n: int, repeats: int, with_reference: bool, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    row = {"n": n, "N": 3 + 2 * n}
    for update in ("sequential", "batch"):
        ekf, L = _mapped_filter(n, rng, update)

        def step():
            ekf.predict((0.5, 0.05), 0.1)
            ekf.update(_observations(rng, L, ekf.x[:3]))

        step()  # warm-up
        row[update] = _time_steps(step, repeats)
        if update == "sequential" and with_reference:
            ref = ReferenceEKFSLAM(M, R)
            ref.xEst, ref.PEst, ref.ids = ekf.x.copy(), ekf.P.copy(), ekf.landmark_ids.tolist()

            def ref_step():
                ref.predict((0.5, 0.05), 0.1)
                ref.update(_observations(rng, L, ref.xEst[:3]))

            row["reference"] = _time_steps(ref_step, max(2, repeats // 10))
    return row


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console
    from rich.table import Table

    sizes = [25, 50, 100, 200, 400] if quick else [25, 50, 100, 200, 400, 800, 1600]
    ref_max = 200 if quick else 800
    repeats = 10 if quick else 20
    console = Console()
    rows = []
    for n in sizes:
        rows.append(measure_single_threaded("slamarena.experiments.benchmarks.ekf_slam", n=n, repeats=repeats, with_reference=n <= ref_max))
        console.log(f"n = {n}: " + ", ".join(f"{k} {v:.4g}" for k, v in rows[-1].items()))
    fit_lo, fit_hi = (100, 400) if quick else (200, 1600)
    exponents = {key: loglog_slope(rows, key, fit_lo, fit_hi) for key in ("sequential", "batch")}
    ref_exp = loglog_slope(rows, "reference", 100 if quick else 200, ref_max)

    table = Table(title=f"EKF-SLAM CPU time per step (predict + {OBSERVATIONS} observations), least of {repeats}")
    for col in ("n", "N", "sequential [ms]", "batch [ms]", "reference [ms]", "reference / sequential"):
        table.add_column(col, justify="right")
    for r in rows:
        ref = r.get("reference")
        table.add_row(str(r["n"]), str(r["N"]), f"{1e3 * r['sequential']:.2f}", f"{1e3 * r['batch']:.2f}",
                      "—" if ref is None else f"{1e3 * ref:.1f}", "—" if ref is None else f"{ref / r['sequential']:.0f}×")
    console.print(table)
    console.print(f"log-log exponent over n ∈ [{fit_lo}, {fit_hi}]: sequential {exponents['sequential']:.2f}, "
                  f"batch {exponents['batch']:.2f} (aim ≤ 2.2); reference {ref_exp:.2f} over n ≤ {ref_max}")
    at = next((r for r in rows if r["n"] == ref_max), None)
    if at is not None:
        console.print(f"speed-up over the literal reference at n = {ref_max}: {at['reference'] / at['sequential']:.0f}× (aim ≥ 50× at n = 800)")
    write_rows(rows, out, "ekf_slam_scaling.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
