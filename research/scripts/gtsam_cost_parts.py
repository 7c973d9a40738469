"""Where the GTSAM pose-graph wrapper's time goes beside Levenberg-Marquardt (notebook 2026-11-28-gtsam-cost.md).

Run from the repository root, one BLAS thread: ``OPENBLAS_NUM_THREADS=1 nice -n 10 .venv/bin/python
research/scripts/gtsam_cost_parts.py [repeats]``. Per staged g2o graph (intel, manhattan, city10000), CPU time, least
of ``repeats`` runs:

* the project's g2o reader, whole and split by the functions it calls (each timed where the reader calls it);
* the graph built three ways: GTSAM's reader on the validated file as the wrapper does it (``pose_graph_factors``:
  the file check, ``readG2o``, the comparisons), ``readG2o`` alone, and one pybind call per factor and value from the
  arrays (``build_pose_graph``).
"""

from __future__ import annotations

import sys
import time


def _reader_parts(path, repeats: int) -> tuple[float, dict[str, float]]:
    """The reader's whole CPU time and the time inside each function it calls (the run with the least total)."""
    from slamarena.datasets.formats import g2o, isam

    spent: dict[str, float] = {}
    patched = {
        (g2o, "records"): "lines and tags",
        (g2o, "record_values"): "numbers: parse, field counts, finite",
        (g2o, "integer_ids"): "integer ids",
        (g2o, "symmetric_from_upper"): "information matrices",
        (isam, "check_positive_definite"): "positive definite (eigvalsh)",
        (g2o, "_graph"): "unique ids, edge ends, PoseGraph",
        (g2o, "fingerprint"): "fingerprint of the arrays",
    }
    originals = {key: getattr(*key) for key in patched}

    def timed(f, label):
        def call(*args, **kwargs):
            t = time.process_time()
            out = f(*args, **kwargs)
            spent[label] = spent.get(label, 0.0) + time.process_time() - t
            return out

        return call

    for (module, name), label in patched.items():
        setattr(module, name, timed(originals[(module, name)], label))
    try:
        runs = []
        for _ in range(repeats):
            spent.clear()
            t = time.process_time()
            g2o.read(path)
            runs.append((time.process_time() - t, dict(spent)))
    finally:
        for (module, name), f in originals.items():
            setattr(module, name, f)
    return min(runs, key=lambda r: r[0])


def _least(f, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.process_time()
        f()
        best = min(best, time.process_time() - t)
    return best


def main(repeats: int = 9) -> None:
    import gtsam

    from slamarena.datasets.formats import g2o
    from slamarena.datasets.registry import resolve
    from slamarena.estimators.gtsam_smoother.pose_graph import (
        PoseGraphOptimizerParams,
        build_pose_graph,
        plain_text,
        pose_graph_factors,
    )

    params = PoseGraphOptimizerParams()
    for name in ("intel", "manhattan", "city10000"):
        dataset = resolve(f"g2o:{name}")
        if not dataset.present():
            print(f"g2o:{name}: not staged")
            continue
        path = dataset.files()["graph"]
        total, parts = _reader_parts(path, repeats)
        graph = g2o.read(path)
        print(f"g2o:{name} ({graph.n_nodes} nodes, {graph.n_edges} edges): the g2o reader {1e3 * total:.2f} ms")
        for label, seconds in parts.items():
            print(f"    {label:40s} {1e3 * seconds:7.2f} ms")

        def read_g2o():
            with plain_text(path) as plain:
                gtsam.readG2o(str(plain), False)

        built = {
            "pose_graph_factors (readG2o on the validated file)": lambda: pose_graph_factors(graph, params),
            "readG2o alone (a .gz decompressed first)": read_g2o,
            "build_pose_graph (from the arrays)": lambda: build_pose_graph(graph, params),
        }
        assert pose_graph_factors(graph, params)[3] == "gtsam.readG2o"
        for label, f in built.items():
            print(f"  {label:52s} {1e3 * _least(f, repeats):7.2f} ms")
        print(
            f"  {'fingerprint + file check (g2o.source_file)':52s} "
            f"{1e3 * _least(lambda: g2o.source_file(graph), repeats):7.2f} ms"
        )


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
