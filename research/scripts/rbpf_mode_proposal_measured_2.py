"""notebook/2026-11-23-rbpf-mode-proposal-measured.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_measured_2.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

from slamarena import datasets
from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    s = datasets.load("carmen:mit-csail")
    for proposal in ("mode",):
        r = relation_error_from_file(
            RBPF(particles=30, proposal=proposal).run(s), s, RelationsParams(match="interpolate")
        )[0]
        print(
            proposal, "30 particles: trans_mean", round(r["trans_mean"], 4), "std", round(r["trans_std"], 4), flush=True
        )


if __name__ == "__main__":
    main()
