"""notebook/2026-11-23-rbpf-mode-proposal-measured.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_measured_5.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path

from slamarena.mapping.rbpf import RBPF


def main() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "mapping"))
    import numpy as np
    import test_rbpf as t
    from conftest import make_sequence

    seq = make_sequence(n=60, odo_sigma=(0.0, 0.0, 0.0))
    fr = t._frozen(seq, 30, 4)
    truth = seq.ground_truth.poses
    for prop in ("gaussian", "mode"):
        for name, s in (("clean", seq), ("frozen", fr)):
            e = RBPF(particles=3, proposal=prop).run(s)
            err = np.hypot(*(e.poses[:, :2] - truth[:, :2]).T)
            print(
                prop,
                name,
                "max before 30",
                err[:30].max().round(3),
                "max from 34",
                err[34:].max().round(3),
                np.round(err[28:40], 3).tolist(),
            )


if __name__ == "__main__":
    main()
