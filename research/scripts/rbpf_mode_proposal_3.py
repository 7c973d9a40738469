"""method/rbpf_mode_proposal.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_3.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path

from slamarena.mapping.rbpf import RBPF
from slamarena.mapping.rbpf.proposal import gauss_newton


def main() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "mapping"))
    import numpy as np
    import test_rbpf as t

    maps, pts, guess, motion_cov = t._target_state()
    p = RBPF.Params()
    info = np.linalg.inv(motion_cov)
    for sigma in (0.25, 1.0):
        for it in (10, 30, 100):
            gn = dict(
                sigma=sigma,
                iterations=it,
                tol_t=1e-6,
                tol_r=1e-6,
                max_step_t=p.max_step_translation,
                max_step_r=p.max_step_rotation,
            )
            m, _ = gauss_newton(maps, pts, guess, info, **gn)
            again, _ = gauss_newton(maps, pts, guess, info, start=m, finest_only=True, **gn)
            d = again - m
            d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
            print(
                "sigma_z",
                sigma,
                "iterations per level",
                it,
                "mode",
                np.round(m[0], 4).tolist(),
                "moved by",
                np.round(1e3 * d[0], 1).tolist(),
            )


if __name__ == "__main__":
    main()
