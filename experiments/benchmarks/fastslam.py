"""``slamarena bench fastslam``: FastSLAM cost per step against the map size n and the particle count M.

The world is ``sim:landmarks`` with n = 50 … 3200 landmarks at a fixed density (the route grows with
n, so the landmarks in view per step — about 8 — do not), known association; the run is long enough
for the timed windows after the first lap. The filter
(:class:`slamarena.estimators.fastslam.FastSLAM`, version 2 unless stated) is driven set by set — the
motion since the last observation set (``predict_twists``), then the set (``update``) — through the
first lap on every ``MAP_STRIDE``-th observation set (which maps every landmark, cheaply), then through
``WINDOWS`` consecutive windows of ``steps`` observation sets after it, timed with
``time.process_time``. Reported per step is the least window mean (the mean includes the resamplings
and the node releases they cause; the least window is the one least disturbed by other processes).

Three series, all measured in one run, each in a child process with one BLAS thread:

* time per step against n at fixed M (the claim: O(M log n) — a write copies the O(log n) nodes on one
  path — so the fitted log-log exponent in n is near 0), and the same filter with an **eager-copy
  map** (:class:`EagerCopyStore`: after every resampling each particle's map is made private, every
  shared node copied — what a FastSLAM with one array map per particle pays, O(M n) per resampling);
* time per step against M at fixed n (exponent near 1: the per-particle work is independent);
* the live map bytes per particle (``LandmarkStore.nbytes() / M``, the ``map_bytes`` of
  ``Estimate.meta``) at the end of the timed windows, shared and eager, against n.

Aims, printed with their verdicts: the exponent in n at most :data:`AIM_EXPONENT_N` (O(M log n) looks flat on a
log-log plot), the exponent in M within :data:`AIM_EXPONENT_M_TOL` of 1.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

from slamarena.estimators.fastslam.storage import LEAF, LandmarkStore, find, writable
from slamarena.experiments.benchmarks import aim, loglog_slope, measure_single_threaded, table, write_rows

STAGED_DATA: dict[str, bool] = {}
MAP_STRIDE = 10
WINDOWS = 3
AIM_EXPONENT_N = 0.2
AIM_EXPONENT_M_TOL = 0.2


@njit(cache=True)
def _privatise(
    n_leaves,
    depth,
    roots,
    inner_child,
    inner_ref,
    leaf_mu,
    leaf_S,
    leaf_state,
    leaf_seen,
    leaf_born,
    leaf_ref,
    free_inner,
    top_inner,
    used_inner,
    free_leaf,
    top_leaf,
    used_leaf,
):
    """Make every particle's tree private: every shared node of every path is copied (path copying on
    one slot per leaf)."""
    for m in range(roots.shape[0]):
        for b in range(n_leaves):
            if find(roots[m], b * LEAF, depth, inner_child)[0] >= 0:
                writable(
                    m,
                    b * LEAF,
                    depth,
                    roots,
                    inner_child,
                    inner_ref,
                    leaf_mu,
                    leaf_S,
                    leaf_state,
                    leaf_seen,
                    leaf_born,
                    leaf_ref,
                    free_inner,
                    top_inner,
                    used_inner,
                    free_leaf,
                    top_leaf,
                    used_leaf,
                )


class EagerCopyStore(LandmarkStore):
    """The reference: copy-on-write storage that copies every duplicated map in full at resampling.
    ``slots()`` gives the number of slots in use (the filter's ``n_slots.max()``)."""

    def __init__(self, particles: int, slots):
        super().__init__(particles)
        self.slots = slots

    def resample(self, ancestors: np.ndarray) -> None:
        super().resample(ancestors)
        n_leaves = -(-self.slots() // LEAF)
        self.reserve(0, self.M * n_leaves)
        _privatise(n_leaves, self.depth, *self.kernel_args())


def _observation_sets(seq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stamps, first and end row of every observation set of the sequence."""
    t = seq.range_bearing.t
    first = np.flatnonzero(np.r_[True, np.diff(t) > 0])
    return t[first], first, np.r_[first[1:], t.size]


def measure(n: int, M: int, steps: int, version: int = 2, eager: bool = False, seed: int = 0) -> dict:
    from slamarena import datasets
    from slamarena.estimators.fastslam import FastSLAM
    from slamarena.estimators.stepping import twist_pieces

    world = dict(n_landmarks=n, seed=seed)
    steps_per_lap = datasets.load("sim:landmarks", **world).meta["route"]["steps_per_lap"]
    seq = datasets.load("sim:landmarks", laps=1 + math.ceil(1.2 * WINDOWS * steps / steps_per_lap), **world)
    slam = FastSLAM(version=version, particles=M, seed=seed)
    slam.reset(seq)
    if eager:
        slam.store = EagerCopyStore(M, lambda: int(slam.n_slots.max()))
    stamps, first, end = _observation_sets(seq)
    lap = seq.t0 + steps_per_lap * seq.meta["dt"]
    z = seq.range_bearing.z
    t_now = seq.t0

    def step(k: int) -> None:
        nonlocal t_now
        v, w, dts = twist_pieces(seq.motion, t_now, stamps[k])
        if dts.size:
            slam.predict_twists(v, w, dts)
        slam.update(z[first[k] : end[k]])
        t_now = stamps[k]

    second = int(np.searchsorted(stamps, lap))
    for k in range(0, second, MAP_STRIDE):  # the first lap maps every landmark
        step(k)
    if second + WINDOWS * steps > stamps.size:
        raise ValueError(
            f"n = {n}: {stamps.size - second} observation sets after the first lap, {WINDOWS * steps} needed"
        )
    windows, resamplings = [], slam.resamplings
    k = second
    for _ in range(WINDOWS):
        clock = time.process_time()
        for _ in range(steps):
            step(k)
            k += 1
        windows.append((time.process_time() - clock) / steps)
    mapped = int(slam.n_slots.max())
    return {
        "n": n,
        "M": M,
        "version": version,
        "eager": eager,
        "mapped": mapped,
        "observations_per_step": float((end[second:k] - first[second:k]).mean()),
        "step": float(min(windows)),
        "resamplings_per_step": (slam.resamplings - resamplings) / (WINDOWS * steps),
        "bytes_per_particle": slam.store.nbytes() / M,
        "dense_bytes_per_particle": mapped * 44.0,
    }


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    sizes = [50, 100, 200, 400, 800] if quick else [50, 100, 200, 400, 800, 1600, 3200, 6400]
    particles = [10, 30, 100, 300] if quick else [10, 30, 100, 300, 1000]
    M_fixed, n_fixed = 100, 400
    steps = 100 if quick else 300
    console = Console()
    module = "slamarena.experiments.benchmarks.fastslam"
    rows_n, rows_m = [], []
    for n in sizes:
        shared = measure_single_threaded(module, n=n, M=M_fixed, steps=steps)
        eager = measure_single_threaded(module, n=n, M=M_fixed, steps=steps, eager=True)
        rows_n.append(dict(shared, eager_step=eager["step"], eager_bytes_per_particle=eager["bytes_per_particle"]))
        console.log(f"n = {n}: {1e3 * shared['step']:.2f} ms/step shared, {1e3 * eager['step']:.2f} eager")
    for M in particles:
        rows_m.append(measure_single_threaded(module, n=n_fixed, M=M, steps=steps))
        console.log(f"M = {M}: {1e3 * rows_m[-1]['step']:.2f} ms/step")
    lo_n, hi_n = sizes[1], sizes[-1]
    exp_n = {
        key: loglog_slope(rows_n, key, lo_n, hi_n)
        for key in ("step", "eager_step", "bytes_per_particle", "eager_bytes_per_particle")
    }
    exp_m = loglog_slope(rows_m, "step", 100 if not quick else 30, particles[-1], size="M")

    by_n = table(
        f"FastSLAM 2.0, M = {M_fixed}, known association: CPU time per step (≈ {rows_n[0]['observations_per_step']:.0f} "
        f"observations), least mean of {WINDOWS} windows of {steps} steps",
        (
            "n",
            "shared [ms]",
            "eager copy [ms]",
            "eager / shared",
            "resamplings / step",
            "live bytes / particle, shared",
            "eager",
            "dense map (44 B/landmark)",
        ),
        justify="right",
    )
    for r in rows_n:
        by_n.add_row(
            str(r["n"]),
            f"{1e3 * r['step']:.2f}",
            f"{1e3 * r['eager_step']:.2f}",
            f"{r['eager_step'] / r['step']:.1f}×",
            f"{r['resamplings_per_step']:.2f}",
            f"{r['bytes_per_particle']:.0f}",
            f"{r['eager_bytes_per_particle']:.0f}",
            f"{r['dense_bytes_per_particle']:.0f}",
        )
    console.print(by_n)
    by_m = table(
        f"FastSLAM 2.0, n = {n_fixed}: CPU time per step against M",
        ("M", "per step [ms]", "per step and particle [µs]"),
        justify="right",
    )
    for r in rows_m:
        by_m.add_row(str(r["M"]), f"{1e3 * r['step']:.2f}", f"{1e6 * r['step'] / r['M']:.1f}")
    console.print(by_m)
    console.print(
        f"log-log exponents over n ∈ [{lo_n}, {hi_n}] at M = {M_fixed}: time per step {exp_n['step']:.2f} "
        f"{aim(f'≤ {AIM_EXPONENT_N} (O(M log n))', exp_n['step'] <= AIM_EXPONENT_N)}, "
        f"eager copy {exp_n['eager_step']:.2f}; live bytes per particle {exp_n['bytes_per_particle']:.2f}, "
        f"eager {exp_n['eager_bytes_per_particle']:.2f}",
        markup=False,
    )
    console.print(
        f"log-log exponent over M at n = {n_fixed}: {exp_m:.2f} "
        f"{aim(f'1 ± {AIM_EXPONENT_M_TOL}', abs(exp_m - 1) <= AIM_EXPONENT_M_TOL)}",
        markup=False,
    )
    write_rows(rows_n, out, "fastslam_scaling_n.csv")
    write_rows(rows_m, out, "fastslam_scaling_M.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
