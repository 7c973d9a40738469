"""``slamarena bench gtsam``: the cost of the GTSAM pose-graph wrapper as a ratio to a bare GTSAM script on the same graph.

For each staged 2D pose graph (g2o: intel, manhattan, city10000; ``--quick``: intel and manhattan), in one child
process with one BLAS thread, CPU time (``time.process_time``), the least of ``repeats`` runs of each, the two
run alternately so that both see the same machine load:

* **ours**: ``datasets.load("g2o:NAME")`` (the project's reader, validated) and
  :class:`~slamarena.estimators.gtsam_smoother.PoseGraphOptimizer` ``.run`` with its defaults (graph built from the
  arrays, Levenberg-Marquardt with tolerances 1e-8, the checks of
  :func:`~slamarena.estimators.gtsam_smoother.graph.optimize`, the poses read back into an ``Estimate``);
* **bare**: the script a GTSAM user writes: ``gtsam.readG2o`` (C++; a ``.gz`` file is decompressed once beforehand,
  outside the timing), a ``PriorFactorPose2`` on node 0 with σ = 1e-6, ``LevenbergMarquardtOptimizer`` with the same
  tolerances, ``gtsam.utilities.extractPose2``.

Printed per graph: both times, the ratio ours / bare with its verdict against the aim (≤ :data:`AIM_RATIO`), our
time split into reading the file, building the graph, optimising (LM alone, as the bare script runs it) and the
rest (the checks and the ``Estimate``), the bare script's into reading and optimising, and whether both reach the
same final error (to 1e-9 relative: readG2o keeps a diagonal information matrix as a diagonal model, ours as a
full one, so the last digits may differ).

Landmark SLAM has no bare script to compare with (the smoother's problem — the between factors' covariances from the
filters' noise propagation — is the project's own), so for ``BatchSmoother()`` on ``sim:landmarks`` with
:data:`LANDMARKS` landmarks (``--quick``: :data:`LANDMARKS_QUICK`) the run is split into its parts instead (least
of :data:`LANDMARK_REPEATS`): the problem (noise propagation), the graph build, the initial values (an iSAM2 run),
Levenberg-Marquardt, and ``run()`` whole.
"""

from __future__ import annotations

import gzip
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

from slamarena.experiments.benchmarks import aim, measure_single_threaded, table, verdict, write_rows

STAGED_DATA: dict[str, bool] = {"g2o:intel": True, "g2o:manhattan": False, "g2o:city10000": False}
GRAPHS = ("intel", "manhattan", "city10000")
AIM_RATIO = 1.1
LANDMARKS, LANDMARKS_QUICK, LANDMARK_REPEATS = 200, 50, 3
TOLERANCE = 1e-8  # PoseGraphOptimizer's default relative and absolute error tolerances


def _plain_g2o(path: Path, tmp: Path) -> Path:
    """The g2o file as plain text (readG2o reads no gzip)."""
    if path.suffix != ".gz":
        return path
    plain = tmp / path.stem
    with gzip.open(path, "rb") as src, open(plain, "wb") as dst:
        shutil.copyfileobj(src, dst)
    return plain


def _lm_params():
    import gtsam

    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(TOLERANCE)
    params.setAbsoluteErrorTol(TOLERANCE)
    return params


def bare(path: Path) -> dict:
    """The bare GTSAM script on a plain g2o file; its parts' CPU times and final error."""
    import gtsam

    t0 = time.process_time()
    graph, initial = gtsam.readG2o(str(path), False)
    graph.add(gtsam.PriorFactorPose2(0, initial.atPose2(0), gtsam.noiseModel.Isotropic.Sigma(3, 1e-6)))
    t1 = time.process_time()
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, _lm_params())
    gtsam.utilities.extractPose2(optimizer.optimize())
    t2 = time.process_time()
    return {"total": t2 - t0, "read": t1 - t0, "optimise": t2 - t1, "error": float(optimizer.error())}


def ours(name: str) -> dict:
    """The project's path: load, then PoseGraphOptimizer.run; the parts timed on the side (not inside the total)."""
    import gtsam

    from slamarena import datasets
    from slamarena.estimators.gtsam_smoother import PoseGraphOptimizer
    from slamarena.estimators.gtsam_smoother.pose_graph import build_pose_graph

    t0 = time.process_time()
    graph = datasets.load(f"g2o:{name}")
    t1 = time.process_time()
    estimate = PoseGraphOptimizer().run(graph)
    t2 = time.process_time()
    factors, values = build_pose_graph(graph, PoseGraphOptimizer.Params())
    t3 = time.process_time()
    gtsam.LevenbergMarquardtOptimizer(factors, values, _lm_params()).optimize()
    t4 = time.process_time()
    return {
        "total": t2 - t0,
        "read": t1 - t0,
        "build": t3 - t2,
        "optimise": t4 - t3,
        "error": float(estimate.diagnostics["final_error"]),
    }


def measure(name: str, repeats: int) -> dict:
    """Least CPU times of ours and the bare script on ``g2o:NAME`` over ``repeats`` alternating runs (in this process)."""
    from slamarena.datasets.registry import resolve

    path = resolve(f"g2o:{name}").files()["graph"]
    with tempfile.TemporaryDirectory() as tmp:
        plain = _plain_g2o(path, Path(tmp))
        runs = {"ours": [], "bare": []}
        ours(name), bare(plain)  # warm-up: imports, first calls
        for _ in range(repeats):
            runs["ours"].append(ours(name))
            runs["bare"].append(bare(plain))
    row = {"graph": name, "repeats": repeats}
    for side, results in runs.items():
        for key in results[0]:
            row[f"{side}_{key}"] = min(r[key] for r in results)
    row["ours_rest"] = max(row["ours_total"] - row["ours_read"] - row["ours_build"] - row["ours_optimise"], 0.0)
    row["ratio"] = row["ours_total"] / row["bare_total"]
    return row


def landmark_parts(n: int, repeats: int) -> dict:
    """Least CPU time of each part of ``BatchSmoother().run`` on ``sim:landmarks`` with n landmarks (in this process)."""
    from slamarena import datasets
    from slamarena.estimators.gtsam_smoother import BatchSmoother
    from slamarena.estimators.gtsam_smoother.graph import optimize

    seq = datasets.load("sim:landmarks", n_landmarks=n, seed=0)
    smoother = BatchSmoother()
    smoother.run(seq)  # warm-up
    best: dict[str, float] = {}
    for _ in range(repeats):
        t0 = time.process_time()
        problem = smoother.problem(seq)
        t1 = time.process_time()
        graph = smoother.graph(problem, problem.cov)
        t2 = time.process_time()
        initial = smoother.initial_values(problem)
        t3 = time.process_time()
        optimize(graph, initial, smoother.params)
        t4 = time.process_time()
        smoother.run(seq)
        t5 = time.process_time()
        parts = {"problem": t1 - t0, "build": t2 - t1, "initial": t3 - t2, "optimise": t4 - t3, "run": t5 - t4}
        best = {k: min(best.get(k, float("inf")), v) for k, v in parts.items()}
    return {"n": n, "poses": problem.n_poses, "observations": int(problem.obs_id.size), **best}


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    from slamarena.datasets.registry import resolve

    console = Console(width=160)
    repeats = 3 if quick else 7
    names = [n for n in (GRAPHS[:2] if quick else GRAPHS) if resolve(f"g2o:{n}").present()]
    if not names:
        console.print("no staged g2o pose graph (sesync_g2o): nothing to measure", markup=False)
        return 0
    rows = []
    for name in names:
        rows.append(measure_single_threaded("slamarena.experiments.benchmarks.gtsam", name=name, repeats=repeats))
        console.log(f"g2o:{name}: ratio {rows[-1]['ratio']:.3f}")
    ratios = table(
        f"GTSAM pose-graph wrapper vs a bare GTSAM script, CPU time, single-threaded, least of {repeats} alternating runs",
        (
            "graph",
            "ours [s]",
            "bare [s]",
            "ours / bare",
            f"ratio ≤ {AIM_RATIO:g}: verdict",
            "ours: read / build / LM / rest [s]",
            "bare: readG2o / LM [s]",
            "same final error",
        ),
    )
    for r in rows:
        same = abs(r["ours_error"] - r["bare_error"]) <= 1e-9 * abs(r["bare_error"])
        ratios.add_row(
            r["graph"],
            f"{r['ours_total']:.3f}",
            f"{r['bare_total']:.3f}",
            f"{r['ratio']:.2f}×",
            verdict(r["ratio"] <= AIM_RATIO),
            " / ".join(f"{r[f'ours_{k}']:.3f}" for k in ("read", "build", "optimise", "rest")),
            f"{r['bare_read']:.3f} / {r['bare_optimise']:.3f}",
            "yes" if same else f"no: {r['ours_error']:.10g} vs {r['bare_error']:.10g}",
        )
    console.print(ratios)
    worst = max(rows, key=lambda r: r["ratio"])
    console.print(
        f"largest ratio ours / bare GTSAM: {worst['ratio']:.2f}× on g2o:{worst['graph']} "
        f"{aim(f'≤ {AIM_RATIO:g}× on every graph', worst['ratio'] <= AIM_RATIO)}",
        markup=False,
    )
    write_rows(rows, out, "gtsam_wrapper.csv")

    n = LANDMARKS_QUICK if quick else LANDMARKS
    row = measure_single_threaded(
        "slamarena.experiments.benchmarks.gtsam", task="landmark_parts", n=n, repeats=LANDMARK_REPEATS
    )
    labels = {
        "problem": "the problem (noise propagation per step)",
        "build": "graph build",
        "initial": "initial values (an iSAM2 run)",
        "optimise": "Levenberg-Marquardt",
        "run": "run() whole (with the marginals)",
    }
    parts = table(
        f"BatchSmoother() on sim:landmarks, n = {n} ({row['poses']} poses, {row['observations']} observations): "
        f"CPU time of its parts, least of {LANDMARK_REPEATS}",
        ("part", "CPU [s]", "share of run()"),
    )
    for key, label in labels.items():
        parts.add_row(label, f"{row[key]:.3f}", f"{100 * row[key] / row['run']:.0f} %")
    console.print(parts)
    write_rows([row], out, "gtsam_landmark_parts.csv")
    return 0


if __name__ == "__main__":
    kwargs = json.loads(sys.argv[1])
    task = {"measure": measure, "landmark_parts": landmark_parts}[kwargs.pop("task", "measure")]
    print(json.dumps(task(**kwargs)))
