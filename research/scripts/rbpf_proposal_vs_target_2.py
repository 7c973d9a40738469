"""notebook/2026-11-23-rbpf-proposal-vs-target.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_proposal_vs_target_2.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys
from pathlib import Path

import numpy as np
from numpy.polynomial.hermite_e import hermegauss

from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sim.laser import simulate
from slamarena.mapping.rbpf import RBPF
from slamarena.mapping.rbpf.proposal import gauss_newton, log_gaussian, residuals


def main() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "mapping"))
    from test_rbpf import _brute_force_target

    def rule(n):
        u, w = hermegauss(n)
        w = w / w.sum()
        U = np.stack(np.meshgrid(u, u, u, indexing="ij"), -1).reshape(-1, 3)
        return U, np.prod(np.stack(np.meshgrid(w, w, w, indexing="ij"), -1).reshape(-1, 3), 1)

    def quad(maps, pts, modes, guesses, Su, sz, n, scale):
        U, W = rule(n)
        _, H, _ = residuals(maps, pts, modes[:, None, :])
        L = scale * np.linalg.cholesky(np.linalg.inv(H / sz**2 + np.linalg.inv(Su)))
        D = np.einsum("pij,kj->pki", L, U)
        X = modes[:, None] + D
        ssr, _, _ = residuals(maps, pts, X)
        e = X - guesses[:, None]
        e[..., 2] = wrap_angle(e[..., 2])
        lc = np.log(W) + (-0.5 * ssr / sz**2 + log_gaussian(e, Su)) + 0.5 * np.sum(U**2, 1) + 1.5 * np.log(2 * np.pi)
        top = lc.max(1, keepdims=True)
        c = np.exp(lc - top)
        tot = c.sum(1)
        w = c / tot[:, None]
        dm = np.einsum("pk,pki->pi", w, D)
        R = D - dm[:, None]
        return np.log(np.abs(np.linalg.det(L))) + top[:, 0] + np.log(tot), np.sqrt(
            np.einsum("pk,pk->p", w, R[..., 2] ** 2)
        )

    class Cap(RBPF):
        def _propose(self, pts, guesses, motion_cov, rng):
            self.n = getattr(self, "n", 0) + 1
            if self.n in (40, 80):
                p = self.params
                sz = p.sigma_likelihood
                modes, _ = gauss_newton(
                    self.maps,
                    pts,
                    guesses,
                    np.linalg.inv(motion_cov),
                    sz,
                    p.iterations,
                    p.tol_translation,
                    p.tol_rotation,
                    p.max_step_translation,
                    p.max_step_rotation,
                )
                B = [
                    _brute_force_target(
                        self.maps.finest.dense(i), pts, guesses[i], motion_cov, sz, modes[i], (0.8, 0.7, 0.6)
                    )
                    for i in range(len(guesses))
                ]
                be = np.array([b[2] for b in B])
                print(
                    "filter step",
                    self.n,
                    "brute force: std of log η over particles",
                    round(be.std(), 3),
                    "median heading sd [mrad]",
                    round(1e3 * np.median([np.sqrt(b[1][2, 2]) for b in B]), 1),
                    flush=True,
                )
                for n, scale in ((3, 1), (5, 1), (5, 2), (7, 2), (7, 3), (9, 3), (9, 4)):
                    le, sd = quad(self.maps, pts, modes, guesses, motion_cov, sz, n, scale)
                    print(
                        f"   {n}^3 points at {scale}× Laplace: brute − rule log η mean {np.mean(be - le):.3f} std {np.std(be - le):.3f}; std of the rule log η {le.std():.3f}; median heading sd {1e3 * np.median(sd):.1f} mrad",
                        flush=True,
                    )
            return super()._propose(pts, guesses, motion_cov, rng)

    s = simulate(
        max_range=4.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=0.085, scan_rate=2.5, laps=2, seed=0
    )
    Cap(particles=30, seed=0).run(s)


if __name__ == "__main__":
    main()
