"""notebook/2026-11-23-rbpf-mode-proposal-measured.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_measured_4.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    cal = dict(sigma_t_min=0.06, sigma_t_per_m=0.0, sigma_r_min=0.03, sigma_r_per_m=0.0)
    for seed in range(10):
        s = simulate(
            max_range=4.0,
            n_beams=91,
            sigma_range=0.02,
            k_r=0.06,
            k_rt=0.03,
            k_t=0.085,
            scan_rate=2.5,
            laps=2,
            seed=seed,
        )
        A = lambda e: round(ate(e, reference_of(s), ATEParams())[0]["rmse"], 3)
        print(
            "world seed",
            seed,
            "mode, calib: one particle",
            A(RBPF(particles=1, proposal="mode", **cal).run(s)),
            "30 particles",
            A(RBPF(particles=30, proposal="mode", **cal).run(s)),
            flush=True,
        )


if __name__ == "__main__":
    main()
