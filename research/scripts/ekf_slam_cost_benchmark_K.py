"""notebook/2026-11-23-ekf-slam-cost-benchmark.md, script K

Run from the repository root: ``for n in 25 800; do OPENBLAS_NUM_THREADS=1 python research/scripts/ekf_slam_cost_benchmark_K.py $n; done``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py);
``--quick`` runs it at the smallest size (``QUICK``), which the slow tests do.
"""

import sys
import time

import numpy as np
from scipy.linalg import blas

from slamarena.experiments.benchmarks.ekf_slam import _mapped_filter, _observations


def main() -> None:
    n = int(sys.argv[1])
    rng = np.random.default_rng(0)
    ekf, L = _mapped_filter(n, rng)
    acc = {}

    def timed(obj, name):
        f = getattr(obj, name)

        def g(*a, **k):
            t = time.perf_counter()
            r = f(*a, **k)
            acc[name] = acc.get(name, 0) + time.perf_counter() - t
            return r

        setattr(obj, name, g)

    for obj, name in (
        (ekf._s, "flush"),
        (ekf._s, "correct_run"),
        (ekf, "_associate"),
        (ekf, "predict"),
        (ekf, "update"),
    ):
        timed(obj, name)
    for r in range(200):
        z = _observations(rng, L, ekf.x[:3])
        if r == 20:
            acc.clear()
            t0 = time.perf_counter()
        ekf.predict((0.5, 0.05), 0.1)
        ekf.update(z)
    T = (time.perf_counter() - t0) / 180
    P = np.asfortranarray(ekf.P)
    U = np.asfortranarray(1e-3 * rng.normal(size=(P.shape[0], 20)))
    blas.dsyrk(-1.0, U, beta=1.0, c=P, lower=1, overwrite_c=1)
    t = time.perf_counter()
    for _ in range(180):
        blas.dsyrk(-1.0, U, beta=1.0, c=P, lower=1, overwrite_c=1)
    print(
        f"n = {n}: step {1e3 * T:.3f} ms, syrk {1e3 * (time.perf_counter() - t) / 180:.3f} ms",
        {k: round(1e3 * v / 180, 3) for k, v in acc.items()},
    )


#: ``--quick``: the smallest run through every line, n = 25 landmarks (the page runs 25 and 800).
QUICK = ["25"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
