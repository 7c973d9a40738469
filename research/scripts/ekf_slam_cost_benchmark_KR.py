"""notebook/2026-11-23-ekf-slam-cost-benchmark.md, script KR (KR)

Run from the repository root: ``OPENBLAS_NUM_THREADS=1 python research/scripts/ekf_slam_cost_benchmark_KR.py 800``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py);
``--quick`` runs it at the smallest size (``QUICK``), which the slow tests do.
"""

import sys
import time

import numpy as np

from slamarena.estimators.ekf_slam import kernels as K
from slamarena.experiments.benchmarks.ekf_slam import _mapped_filter, _observations


def main() -> None:
    n = int(sys.argv[1])
    rng = np.random.default_rng(0)
    ekf, L = _mapped_filter(n, rng)
    for r in range(20):
        z = _observations(rng, L, ekf.x[:3])
        ekf.predict((0.5, 0.05), 0.1)
        ekf.update(z)
    s = ekf._s
    s._refresh_stored_entries()
    N = s.n
    s._reserve(40)
    z = _observations(rng, L, ekf.x[:3])
    slots = np.array([ekf._slot[int(i)] for i in z[:, 2]], dtype=np.int64)
    Z = np.ascontiguousarray(z[:, :2])
    R = np.ascontiguousarray(np.broadcast_to(np.diag([0.01, 3e-4]), (10, 2, 2)))
    XL = np.zeros((10, 3))
    ML = np.zeros((10, 2))
    x0 = s._x.copy()
    pend0 = tuple(a.copy() for a in s._pending)

    def reset():
        s._x[:] = x0
        for a, b in zip(s._pending, pend0):
            a[:] = b

    for name, f, extra in (("projected", K._projected_run, (3,)), ("rows", K._rows_run, (False, 3))):
        reset()
        f(s._P, N, s._Ut, s._Ust, s._sg, 0, s._pending, s._stored_entries, s._x[:N], slots, XL, ML, True, Z, R, *extra)
        ts = []
        for _ in range(100):
            reset()
            t = time.perf_counter()
            out = f(
                s._P,
                N,
                s._Ut,
                s._Ust,
                s._sg,
                0,
                s._pending,
                s._stored_entries,
                s._x[:N],
                slots,
                XL,
                ML,
                True,
                Z,
                R,
                *extra,
            )
            ts.append(time.perf_counter() - t)
        print(name, f"{1e6 * np.min(ts):.0f} us (median {1e6 * np.median(ts):.0f})", out[0], s._x[:3])


#: ``--quick``: the smallest run through every line, n = 25 landmarks (the page runs 800).
QUICK = ["25"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
