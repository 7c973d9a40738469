"""notebook/2026-11-23-fastslam-consistency.md, script 2

Run from the repository root: ``python research/scripts/fastslam_consistency_2.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena.estimators.fastslam import FastSLAM


def main() -> None:
    R, M_u = np.diag([0.1**2, np.radians(1.0) ** 2]), np.diag([0.1**2, 0.05**2])  # the simulator's noise
    first = [[5.0, 0.3, 0], [3.0, -0.8, 1], [7.0, 1.2, 2], [1.5, -0.2, 3]]  # four landmarks mapped from the start pose
    for steps in (1, 10):
        out = {}
        for version in (1, 2):
            f = FastSLAM(
                version=version, particles=200_000, seed=1, range_bearing_cov=R, twist_cov=M_u, resample_threshold=1e-9
            )
            f.update(first)
            for _ in range(steps):
                f.predict([1.0, 0.1], 0.1)
            xhat, P = f.predicted()
            ids, mu, _ = f.landmarks(0)
            truth = xhat[0] + np.sqrt(np.diag(P[0])) * [1.0, -0.5, 1.0]  # a pose one σ off the prediction
            d = mu - truth[:2]
            f.update(np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - truth[2], ids]))
            w = np.exp(f.last_log_w - f.last_log_w.max())
            w /= w.sum()
            mean = w @ f.last_sampled
            out[version] = (mean, np.sqrt(w @ (f.last_sampled - mean) ** 2), np.sqrt(np.diag(P[0])))
        (m1, s1, prior), (m2, s2, _) = out[1], out[2]
        print(
            f"{steps} step(s): prior std {np.round(prior, 5)}; 1.0 (exact) mean {np.round(m1, 5)} std {np.round(s1, 5)}; "
            f"2.0 proposal mean {np.round(m2, 5)} std {np.round(s2, 5)}; 2.0 − 1.0 in posterior σ: {np.round((m2 - m1) / s1, 3)}"
        )


if __name__ == "__main__":
    main()
