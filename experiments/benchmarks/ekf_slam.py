"""``slamarena bench ekf-slam``: EKF-SLAM cost per step against the map size, next to the cost of one pass over P.

For n = 25 … 3200 landmarks (N = 3 + 2n), a filter holding n mapped landmarks does steps of
one prediction plus an update with 10 observations of known landmarks (simulated before each step,
outside the timed part). Reported, all from
the same run: the least CPU time (``time.process_time``; the minimum is the estimate least
disturbed by other processes on a shared machine) per step, over the repeats of a process and
over ``trials`` processes per n (3; one with ``--quick``), run interleaved — every n once, then
every n again — because a process's time drifts with the machine's state by ±10 % between
processes (seen as exponents that moved by ±0.15 from run to run with one process per n); the
exponents of each trial are printed beside those of the least. Timed per step:

* the filter with sequential updates (the default: the set's N×N update deferred and applied
  once, rank 20), with batched updates, and with the sequential update applied per observation
  (``defer_covariance=False``, the filter before the deferral: one pass over P per observation);
* the literal dense reference (``slamarena.estimators.ekf_slam.reference``; up to n = 800, since it
  costs O(N³) per observation; in the first trial only), and the ratio to it;
* the floor the O(n²) step is measured against: a rank-20 symmetric update of a P of the same
  size (``scipy.linalg.blas.dsyrk``, one triangle, in place) and one streaming pass over P
  (``P *= 1`` in place).

Aims: at n = 1600 and 3200 the sequential step costs at most 2× the rank-20 syrk; the log-log
exponent over n ∈ [800, 3200] is 2.0 ± 0.2 (the memory-bound O(n²) regime); the ratio to the
literal reference at n = 800 is printed. ``--quick`` (n ≤ 400) cannot show either aim — below
n ≈ 800 P fits in the cache and the fixed per-step cost dominates — so its lines say "not measurable
at this size" beside the values it measured.

Everything is timed single-threaded (the measurement runs in a child process started with
``OPENBLAS_NUM_THREADS=1`` etc.), so the ratios compare algorithms, not thread counts, and
idle BLAS threads spinning on a busy machine do not pollute the CPU times.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.linalg import blas

from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.reference import ReferenceEKFSLAM
from slamarena.estimators.models import observe
from slamarena.experiments.benchmarks import aim, loglog_slope, measure_single_threaded, table, write_rows

STAGED_DATA: dict[str, bool] = {}
OBSERVATIONS = 10
#: the aims: sizes at which they are judged, the syrk ratio's bound, the exponent's target and tolerance
AIM_SIZES = (1600, 3200)
AIM_FIT = (800, 3200)
AIM_SYRK_RATIO = 2.0
AIM_EXPONENT, AIM_EXPONENT_TOL = 2.0, 0.2
R = np.diag([0.1**2, np.radians(1.0) ** 2])
M = np.diag([0.1**2, 0.05**2])
#: filter variants timed: column name → EKFSLAM parameters
VARIANTS = {
    "sequential": dict(update="sequential"),
    "batch": dict(update="batch"),
    "per_observation": dict(update="sequential", defer_covariance=False),
}


def _mapped_filter(n: int, rng: np.random.Generator, **params) -> tuple[EKFSLAM, np.ndarray]:
    """A filter that has already mapped n landmarks scattered around the robot."""
    radius = 5.0 + rng.uniform(0, 45.0, n)
    angle = rng.uniform(-np.pi, np.pi, n)
    L = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    ekf = EKFSLAM(twist_cov=M, range_bearing_cov=R, initial_cov=[0.01, 0.01, 0.001], capacity=3 + 2 * n, **params)
    z = observe(np.zeros(3), L) + rng.normal(size=(n, 2)) * np.sqrt(np.diag(R))
    for k in range(0, n, 50):
        ekf.update(np.column_stack([z[k : k + 50], np.arange(k, min(k + 50, n))]))
    return ekf, L


def _observations(rng, L, pose) -> np.ndarray:
    ids = rng.choice(L.shape[0], OBSERVATIONS, replace=False)
    z = observe(pose, L[ids]) + rng.normal(size=(OBSERVATIONS, 2)) * np.sqrt(np.diag(R))
    return np.column_stack([z, ids])


def _time_steps(step, repeats: int, prepare=None) -> float:
    """Least CPU time of ``step(prepare())`` over the repeats (robust to other processes on a shared machine); ``prepare``
    (untimed) makes the step's input."""
    times = []
    for _ in range(repeats):
        args = () if prepare is None else (prepare(),)
        t = time.process_time()
        step(*args)
        times.append(time.process_time() - t)
    return float(np.min(times))


def measure(n: int, repeats: int, with_reference: bool, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    row = {"n": n, "N": 3 + 2 * n}
    for name, params in VARIANTS.items():
        ekf, L = _mapped_filter(n, rng, **params)

        def step(z, ekf=ekf):  # bound now: the loop rebinds ekf and L for the next variant
            ekf.predict((0.5, 0.05), 0.1)
            ekf.update(z)

        def observations(ekf=ekf, L=L):  # simulated at the pose before the step, untimed
            return _observations(rng, L, ekf.x[:3])

        step(observations())  # warm-up
        row[name] = _time_steps(step, repeats, observations)
        if name == "sequential":
            P = np.asfortranarray(ekf.P)
            U = np.asfortranarray(1e-3 * rng.normal(size=(P.shape[0], 2 * OBSERVATIONS)))
            blas.dsyrk(-1.0, U, beta=1.0, c=P, lower=1, overwrite_c=1)  # warm-up
            row["syrk20"] = _time_steps(lambda: blas.dsyrk(-1.0, U, beta=1.0, c=P, lower=1, overwrite_c=1), repeats)
            row["one_pass"] = _time_steps(lambda: np.multiply(P, 1.0, out=P), repeats)
            del P
            if with_reference:
                ref = ReferenceEKFSLAM(M, R)
                ref.xEst, ref.PEst, ref.ids = ekf.x.copy(), ekf.P.copy(), ekf.landmark_ids.tolist()

                def ref_step(z):
                    ref.predict((0.5, 0.05), 0.1)
                    ref.update(z)

                row["reference"] = _time_steps(
                    ref_step, max(2, repeats // 10), lambda: _observations(rng, L, ref.xEst[:3])
                )
        del ekf
    return row


def summary(
    rows: list[dict], exponents: dict[str, float], fit: tuple[int, int], ref_exp: float, ref_max: int
) -> list[str]:
    """The lines under the table, each aim with its verdict: the exponents over ``fit`` (judged only when ``fit`` is
    :data:`AIM_FIT`), the syrk ratio at the largest sizes (judged at :data:`AIM_SIZES`), the speed-up at ``ref_max``."""
    seq = exponents["sequential"]
    exponent_met = abs(seq - AIM_EXPONENT) <= AIM_EXPONENT_TOL if tuple(fit) == AIM_FIT else None
    exponent_aim = aim(
        f"{AIM_EXPONENT} ± {AIM_EXPONENT_TOL} over n ∈ [{AIM_FIT[0]}, {AIM_FIT[1]}]",
        exponent_met,
        f"this run fits n ≤ {fit[1]}",
    )
    lines = [
        f"log-log exponent over n ∈ [{fit[0]}, {fit[1]}]: "
        + ", ".join(f"{k} {v:.2f}" for k, v in exponents.items())
        + f"; for the filter {exponent_aim}; reference {ref_exp:.2f} over n ≤ {ref_max}"
    ]
    largest = max(r["n"] for r in rows)
    for r in rows:
        if r["n"] in AIM_SIZES or (r["n"] == largest and largest < AIM_SIZES[0]):
            ratio = r["sequential"] / r["syrk20"]
            ratio_aim = aim(
                f"≤ {AIM_SYRK_RATIO:g}× at n = {AIM_SIZES[0]} and {AIM_SIZES[1]}",
                ratio <= AIM_SYRK_RATIO if r["n"] in AIM_SIZES else None,
                f"this run stops at n = {largest}",
            )
            lines.append(
                f"n = {r['n']}: sequential / rank-20 syrk = {ratio:.2f}× {ratio_aim}, "
                f"batch / syrk = {r['batch'] / r['syrk20']:.2f}×, "
                f"per observation / sequential = {r['per_observation'] / r['sequential']:.2f}×"
            )
    at = next((r for r in rows if r["n"] == ref_max and "reference" in r), None)
    if at is not None:
        lines.append(f"speed-up over the literal reference at n = {ref_max}: {at['reference'] / at['sequential']:.0f}×")
    return lines


def main(out: Path | None = None, quick: bool = False, trials: int | None = None) -> int:
    from rich.console import Console

    sizes = [25, 50, 100, 200, 400] if quick else [25, 50, 100, 200, 400, 800, 1600, 3200]
    ref_max = 200 if quick else 800
    repeats = 10 if quick else 20
    trials = trials or (1 if quick else 3)
    fit_lo, fit_hi = (100, 400) if quick else (800, 3200)
    console = Console()
    runs = []  # one list of rows per trial; a trial measures every n once, each n in a fresh process
    for trial in range(trials):
        runs.append([])
        for n in sizes:
            runs[-1].append(
                measure_single_threaded(
                    "slamarena.experiments.benchmarks.ekf_slam",
                    n=n,
                    repeats=repeats,
                    with_reference=trial == 0 and n <= ref_max,
                    seed=trial,
                )
            )
            console.log(
                f"trial {trial + 1}/{trials}, n = {n}: " + ", ".join(f"{k} {v:.4g}" for k, v in runs[-1][-1].items())
            )
    rows = [{k: min(r[k] for r in same if k in r) for k in same[0]} for same in zip(*runs)]  # least over the trials
    keys = (*VARIANTS, "syrk20")
    exponents = {key: loglog_slope(rows, key, fit_lo, fit_hi) for key in keys}
    per_trial = {key: [loglog_slope(run, key, fit_lo, fit_hi) for run in runs] for key in keys}
    ref_exp = loglog_slope(rows, "reference", 100 if quick else 200, ref_max)

    out_table = table(
        f"EKF-SLAM CPU time per step (predict + {OBSERVATIONS} observations), least of {repeats} repeats × {trials} "
        "trials, single-threaded",
        (
            "n",
            "N",
            "sequential [ms]",
            "batch [ms]",
            "per observation [ms]",
            "rank-20 syrk [ms]",
            "one pass [ms]",
            "sequential / syrk",
            "reference [ms]",
            "reference / sequential",
        ),
        justify="right",
    )
    for r in rows:
        ref = r.get("reference")
        out_table.add_row(
            str(r["n"]),
            str(r["N"]),
            *(f"{1e3 * r[k]:.2f}" for k in ("sequential", "batch", "per_observation", "syrk20", "one_pass")),
            f"{r['sequential'] / r['syrk20']:.2f}×",
            "—" if ref is None else f"{1e3 * ref:.1f}",
            "—" if ref is None else f"{ref / r['sequential']:.0f}×",
        )
    console.print(out_table)
    for line in summary(rows, exponents, (fit_lo, fit_hi), ref_exp, ref_max):
        console.print(line, markup=False)
    if trials > 1:
        console.print(
            "the same exponents trial by trial: "
            + "; ".join(f"{k} " + ", ".join(f"{v:.2f}" for v in vs) for k, vs in per_trial.items()),
            markup=False,
        )
    write_rows(rows, out, "ekf_slam_scaling.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
