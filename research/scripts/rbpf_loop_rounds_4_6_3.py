"""notebook/2026-11-23-rbpf-loop-rounds-4-6.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_4_6_3.py 50 intel fr079 fr-clinic``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

from slamarena.datasets.registry import load
from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    P = int(sys.argv[1])
    for name in sys.argv[2:]:
        s = load(f"carmen:{name}")
        e = RBPF(particles=P, seed=0, step_halvings=4).run(s)
        r = relation_error_from_file(e, s, RelationsParams(match="interpolate"))[0]
        print(
            name,
            P,
            "all %.4f ± %.4f, local %.4f ± %.4f, resamplings %d"
            % (
                r["trans_mean"],
                r["trans_std"],
                r["local_trans_mean"],
                r["local_trans_std"],
                e.meta["resampling_events"],
            ),
        )


if __name__ == "__main__":
    main()
