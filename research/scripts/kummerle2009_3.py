"""notebook/2026-11-23-kummerle2009.md, an inline command

Run from the repository root: ``python research/scripts/kummerle2009_3.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

from slamarena import datasets
from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
from slamarena.mapping.laser_slam import LaserSLAM


def main() -> None:
    for log in ("intel", "fr079", "mit-csail", "fr-clinic"):
        s = datasets.load(f"carmen:{log}")
        for kw in ({}, {"refine_neighbours": 0}):
            e = LaserSLAM(**kw).run(s)
            sc, _ = relation_error_from_file(e, s, RelationsParams(match="interpolate"))
            print(
                log,
                kw,
                sc["trans_mean"],
                sc["trans_std"],
                sc["local_trans_mean"],
                sc["local_trans_std"],
                sc["rot_mean"],
                sc["rot_std"],
                e.meta["seconds"],
            )


if __name__ == "__main__":
    main()
