"""notebook/2026-11-23-fastslam-consistency.md, script 3

Run from the repository root: ``python research/scripts/fastslam_consistency_3.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np
from scipy.special import logsumexp

from slamarena.datasets.sim.landmarks import simulate
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.fastslam.filter import _sqrt_batch


def main() -> None:
    def h(x, mu):  # range-bearing and ∂h/∂μ at poses x (..., 3)
        d = mu - x[..., :2]
        q = (d**2).sum(-1)
        r = np.sqrt(q)
        Hm = np.stack([np.stack([d[..., 0] / r, d[..., 1] / r], -1), np.stack([-d[..., 1] / q, d[..., 0] / q], -1)], -2)
        return np.stack([r, np.arctan2(d[..., 1], d[..., 0]) - x[..., 2]], -1), Hm

    def log_n(nu, S):  # log N(ν; 0, S), batched
        nu = nu.copy()
        nu[..., 1] = (nu[..., 1] + np.pi) % (2 * np.pi) - np.pi
        return (
            -0.5 * np.einsum("...i,...ij,...j->...", nu, np.linalg.inv(S), nu)
            - 0.5 * np.log(np.linalg.det(S))
            - np.log(2 * np.pi)
        )

    rng, spread, error, calls = np.random.default_rng(1), [], [], [0]
    f = FastSLAM(version=2, particles=30, seed=0)
    update = f.update

    def checked(z):  # every 50th update: each particle's 2.0 weight against the exact marginal likelihood
        calls[0] += 1
        z = np.asarray(z, dtype=float)
        if calls[0] % 50 == 0:
            xhat, P = f.predicted()
            mu, S, state = f.store.gather(int(f.n_slots.max()))
            slots = [f._slot_of_id.get(int(i), -1) for i in z[:, 2]]
            lin, exact = np.zeros(f.M), np.zeros(f.M)
            for m, A in enumerate(_sqrt_batch(P)):
                X = xhat[m] + rng.standard_normal((20_000, 3)) @ A.T
                ll, xb, Sx = 0.0, xhat[m].copy(), P[m].copy()
                for zj, s in zip(z, slots):
                    if s < 0 or state[m, s] == 0:
                        continue
                    Sig = S[m, s, [0, 1, 1, 2]].reshape(2, 2)
                    zh, Hm = h(X, mu[m, s])
                    ll = ll + log_n(
                        zj[:2] - zh, Hm @ Sig @ np.swapaxes(Hm, -1, -2) + f.R
                    )  # exact: the integral over the pose
                    zb, Hmb = h(xb, mu[m, s])  # 2.0: the sequential linearised normaliser
                    Hx, Q = np.hstack([-Hmb, [[0.0], [-1.0]]]), Hmb @ Sig @ Hmb.T + f.R
                    L = Hx @ Sx @ Hx.T + Q
                    lin[m] += log_n(zj[:2] - zb, L)
                    K = Sx @ Hx.T @ np.linalg.inv(L)
                    nu = zj[:2] - zb
                    nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
                    xb, Sx = xb + K @ nu, (np.eye(3) - K @ Hx) @ Sx @ (np.eye(3) - K @ Hx).T + K @ Q @ K.T
                exact[m] = logsumexp(ll) - np.log(len(X))
            spread.append(lin.std())
            error.append((exact - lin).std())
        return update(z)

    f.update = checked
    f.run(simulate(laps=2, seed=0))
    print(
        f"{len(error)} updates: spread of the 2.0 log weights across particles median {np.median(spread):.2f} (range {min(spread):.2f}–{max(spread):.2f}); "
        f"spread of their error (exact − linearised) median {np.median(error):.3f}, max {max(error):.3f} nats"
    )


if __name__ == "__main__":
    main()
