"""method/rbpf_mode_proposal.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_1.py``.
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

    P = 400
    maps, pts, guess, motion_cov = t._target_state(particles=P)
    p = RBPF.Params()
    info = np.linalg.inv(motion_cov)
    guesses = np.repeat(guess, P, 0)
    rng = np.random.default_rng(1)
    x = guesses + rng.standard_normal((P, 3)) @ np.linalg.cholesky(motion_cov).T
    for sz in (1.0, 0.5):
        gn = dict(
            sigma=sz,
            iterations=p.iterations,
            tol_t=p.tol_translation,
            tol_r=p.tol_rotation,
            max_step_t=p.max_step_translation,
            max_step_r=p.max_step_rotation,
        )
        modes0, _ = gauss_newton(maps, pts, guess, info, **gn)
        m, _ = gauss_newton(maps, pts, guesses, info, start=x, **gn)
        d = m - modes0
        d[:, 2] = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
        print(
            sz,
            "optimum of tau from the draws: sd",
            np.round(d.std(0) * 1e3, 1),
            "share within 2 cm / 10 mrad of the mode from the guess",
            np.mean(np.all(np.abs(d) < [0.02, 0.02, 0.01], 1)),
        )


if __name__ == "__main__":
    main()
