"""notebook/2026-11-23-rbpf-implicit-loop-closure.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_implicit_loop_closure_1.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    for kt in (0.02, 0.085):
        s = simulate(max_range=4.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=kt, scan_rate=2.5, laps=2)
        A = lambda p: ate(Estimate("x", s.scans.t, p), reference_of(s), ATEParams())[0]["rmse"]
        print(
            "k_t",
            kt,
            "GridSLAM",
            round(A(GridSLAM().run(s).poses), 3),
            "1 particle",
            round(A(RBPF(particles=1).run(s).poses), 3),
        )
        for name, kw in (("before", dict(sigma_t_min=0.1, sigma_r_min=0.1, slip_t=0.0, slip_r=0.0)), ("defaults", {})):
            for seed in range(5):
                f = RBPF(particles=30, seed=seed, **kw)
                best = A(f.run(s).poses)
                g = RBPF(particles=30, seed=seed, resample_threshold=1e-9, **kw)
                g.run(s)
                print(
                    " ",
                    name,
                    seed,
                    "best",
                    round(best, 3),
                    "no resampling: best",
                    round(A(g.trajectory(g.best)), 3),
                    "best of 30 lineages",
                    round(min(A(g.trajectory(i)) for i in range(30)), 3),
                    flush=True,
                )


if __name__ == "__main__":
    main()
