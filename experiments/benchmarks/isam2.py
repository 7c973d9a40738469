"""``slamarena bench isam2``: iSAM2 time per step against the map size — the other side of ``bench ekf-slam``.

The scenario of ``experiments/benchmarks/ekf_slam.py``: n = 25 … 1600 landmarks scattered 5–50 m
around the robot, all mapped from the start pose (the first update adds them, like the EKF
benchmark's pre-mapped filter); then steps of one motion (v, ω) = (0.5, 0.05) for 0.1 s and an
update with 10 observations of randomly chosen known landmarks, with the same noise
(M = diag(0.1², 0.05²), R = diag(0.1², (1°)²)). The run goes through the estimator itself
(:class:`slamarena.estimators.gtsam_smoother.ISAM2Smoother` on a :class:`~slamarena.datasets.sequence.Sequence`), so
the time is the one it records per step (``Estimate.step_time``: the iSAM2 update plus reading
the new pose), here as CPU time (``step_clock="cpu"``, like the EKF benchmark's ``process_time``);
reported are the mean (which includes the periodic relinearisations, every
``relinearize_skip`` = 10 steps) and the median over the steps after the first ``WARMUP``, their
log-log slopes over n, and the ratio to the smallest map. Each size runs in a child
process with one BLAS thread, as the EKF benchmark does.

iSAM2 re-eliminates only the cliques touched by a step; the 10 observed landmarks are random,
so a step touches the part of the Bayes tree that joins them to the new pose. The slope says
how that grows with n (the EKF's per-step cost is O(n²), slope ≈ 2).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from slamarena.experiments.benchmarks import loglog_slope, measure_single_threaded, table, write_rows

STAGED_DATA: dict[str, bool] = {}
OBSERVATIONS = 10
R = np.diag([0.1**2, np.radians(1.0) ** 2])
M = np.diag([0.1**2, 0.05**2])
WARMUP = 10


def scenario(n: int, steps: int, seed: int = 0):
    """The Sequence of the EKF-SLAM scaling benchmark: n landmarks mapped at t = 0, then ``steps`` steps."""
    from slamarena.datasets.geometry import accumulate
    from slamarena.datasets.sequence import LandmarkMap, Noise, RangeBearing, Sequence, Twist
    from slamarena.estimators.models import EULER, observe

    rng = np.random.default_rng(seed)
    radius = 5.0 + rng.uniform(0, 45.0, n)
    angle = rng.uniform(-np.pi, np.pi, n)
    L = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    dt = 0.1
    t = dt * np.arange(steps)
    v, w = np.full(steps, 0.5), np.full(steps, 0.05)
    truth = accumulate(np.zeros(3), EULER.increment(v, w, dt))
    sets = [(0.0, np.arange(n), truth[0])] + [
        (dt * (k + 1), rng.choice(n, OBSERVATIONS, replace=False), truth[k + 1]) for k in range(steps)
    ]
    stamps = np.concatenate([np.full(ids.size, s) for s, ids, _ in sets])
    ids = np.concatenate([ids for _, ids, _ in sets])
    z = np.concatenate([observe(pose, L[i]) for _, i, pose in sets]) + rng.normal(size=(ids.size, 2)) * np.sqrt(
        np.diag(R)
    )
    noisy_v = v + rng.normal(0, np.sqrt(M[0, 0]), steps)
    noisy_w = w + rng.normal(0, np.sqrt(M[1, 1]), steps)
    return Sequence(
        name=f"isam2-bench(n={n})",
        motion=Twist(t=t, v=noisy_v, omega=noisy_w, dt=np.full(steps, dt)),
        range_bearing=RangeBearing(t=stamps, range=z[:, 0], bearing=z[:, 1], landmark_id=ids),
        landmarks=LandmarkMap(ids=np.arange(n), xy=L),
        initial_pose=np.zeros(3),
        noise=Noise(twist_cov=M, range_bearing_cov=R),
    )


def measure(n: int, steps: int, seed: int = 0) -> dict:
    from slamarena.estimators.gtsam_smoother import ISAM2Smoother

    est = ISAM2Smoother(motion_model="euler", covariances=False, final_updates=0, step_clock="cpu").run(
        scenario(n, steps, seed)
    )
    per_step = est.step_time[1 + WARMUP :]
    return {
        "n": n,
        "steps": int(per_step.size),
        "mean": float(np.mean(per_step)),
        "median": float(np.median(per_step)),
        "p90": float(np.percentile(per_step, 90)),
        "first": float(est.step_time[0]),
    }


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    sizes = [25, 50, 100, 200, 400] if quick else [25, 50, 100, 200, 400, 800, 1600]
    steps = 60 if quick else 200
    console = Console()
    rows = []
    for n in sizes:
        rows.append(measure_single_threaded("slamarena.experiments.benchmarks.isam2", n=n, steps=steps))
        console.log(f"n = {n}: mean {1e3 * rows[-1]['mean']:.2f} ms/step, median {1e3 * rows[-1]['median']:.2f}")
    fit_lo, fit_hi = (100, 400) if quick else (200, 1600)
    exponents = {key: loglog_slope(rows, key, fit_lo, fit_hi) for key in ("mean", "median")}
    steps_table = table(
        f"iSAM2 CPU time per step (1 pose + {OBSERVATIONS} observations) over {rows[0]['steps']} steps",
        ("n", "mean [ms]", "median [ms]", "p90 [ms]", f"mean vs n = {sizes[0]}", "first update (maps all n) [ms]"),
        justify="right",
    )
    for r in rows:
        steps_table.add_row(
            str(r["n"]),
            f"{1e3 * r['mean']:.2f}",
            f"{1e3 * r['median']:.2f}",
            f"{1e3 * r['p90']:.2f}",
            f"{r['mean'] / rows[0]['mean']:.1f}×",
            f"{1e3 * r['first']:.1f}",
        )
    console.print(steps_table)
    console.print(
        f"log-log exponent of the step time over n ∈ [{fit_lo}, {fit_hi}]: mean {exponents['mean']:.2f}, "
        f"median {exponents['median']:.2f} (EKF-SLAM: O(n²) per step, see `slamarena bench ekf-slam`)",
        markup=False,
    )
    write_rows(rows, out, "isam2_scaling.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
