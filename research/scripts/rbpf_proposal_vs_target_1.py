"""notebook/2026-11-23-rbpf-proposal-vs-target.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_proposal_vs_target_1.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path


def main() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "mapping"))
    import numpy as np
    import test_rbpf as t

    for sz, half in ((0.25, (0.08, 0.03, 0.02)), (1.0, (0.8, 0.7, 0.6)), (0.5, (0.3, 0.1, 0.06))):
        (mu, cov, le), (mean, bcov, ble, face) = t._proposal_and_brute_force(sz, half)
        print(
            sz,
            "sd quad",
            np.round(np.sqrt(np.diag(cov)) * 1e3, 2),
            "brute",
            np.round(np.sqrt(np.diag(bcov)) * 1e3, 2),
            "mean diff",
            np.round((mu - mean) * 1e3, 2),
            "log eta",
            round(le, 3),
            round(ble, 3),
            "face",
            f"{face:.1e}",
        )


if __name__ == "__main__":
    main()
