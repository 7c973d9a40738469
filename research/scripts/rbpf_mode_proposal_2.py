"""method/rbpf_mode_proposal.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_2.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path

from slamarena.mapping.rbpf import RBPF
from slamarena.mapping.rbpf.proposal import gauss_newton, quadrature, residuals


def main() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "mapping"))
    import numpy as np
    import test_rbpf as t

    W = lambda d: np.concatenate([d[:, :2], ((d[:, 2:] + np.pi) % (2 * np.pi) - np.pi)], 1)
    P = 400
    maps, pts, guess, motion_cov = t._target_state(particles=P)
    for sigma in (1.0, 0.5):
        f = RBPF(particles=P, proposal="mode", sigma_likelihood=sigma)
        f.maps = maps
        p = f.params
        info = np.linalg.inv(motion_cov)
        guesses = np.repeat(guess, P, axis=0)
        poses, fb, le, _ = f._propose(pts, guesses, motion_cov, np.random.default_rng(1))
        g = RBPF(particles=P, proposal="gaussian", sigma_likelihood=sigma)
        g.maps = maps
        gp, _, gle, _ = g._propose(pts, guesses, motion_cov, np.random.default_rng(1))
        modes, _ = gauss_newton(
            maps,
            pts,
            guess,
            info,
            sigma,
            p.iterations,
            p.tol_translation,
            p.tol_rotation,
            p.max_step_translation,
            p.max_step_rotation,
        )
        mu, cov, tle, _ = quadrature(maps, pts, modes, guess, motion_cov, sigma)
        _, H, _ = residuals(maps, pts, modes[:, None, :])
        A_inv = np.linalg.inv(H[0] / sigma**2 + info)
        d = W(poses - modes)
        dg = W(gp - modes)
        print(
            sigma,
            "fallbacks",
            fb,
            "mode: mean",
            np.round(d.mean(0) * 1e3, 1),
            "sd",
            np.round(d.std(0) * 1e3, 1),
            "| gaussian: sd",
            np.round(dg.std(0) * 1e3, 1),
            "quad sd",
            np.round(np.sqrt(np.diag(cov[0])) * 1e3, 1),
            "| shrunk theory",
            np.round(np.sqrt(np.diag(A_inv @ info @ A_inv)) * 1e3, 1),
            "| log eta",
            round(tle[0], 3),
            "mode min/med/max",
            np.round(np.percentile(le, [0, 50, 100]), 3),
            "gauss",
            np.round(np.percentile(gle, [0, 50, 100]), 3),
        )


if __name__ == "__main__":
    main()
