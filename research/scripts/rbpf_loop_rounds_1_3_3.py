"""notebook/2026-11-23-rbpf-loop-rounds-1-3.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_1_3_3.py 0 1 2 3 4 5 6 7 8 9``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np

from slamarena.datasets.geometry import wrap_angle


def main() -> None:
    def local(est, truth):
        d = est[..., :2] - truth[..., :2]
        c, s = np.cos(truth[..., 2]), np.sin(truth[..., 2])
        return np.stack(
            [c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], wrap_angle(est[..., 2] - truth[..., 2])], -1
        )

    for seed in map(int, sys.argv[1:]):
        z = np.load(f"/tmp/long_loop_seed{seed}.npz")
        truth = z["truth"]
        lap = (len(truth) - 1) // 2
        k = lap - 25
        first = z["neff_t"] < z["t"][lap]
        g = local(z["grid"][k], truth[k])
        b = local(z["best"][k], truth[k])
        p = local(z["population"][k], truth[k])
        sd = p.std(0)
        up = np.arange(p.shape[0])
        for j in range(k, lap // 2, -1):
            up = z["parents"][j, up]
        print(
            seed,
            "GridSLAM",
            np.round(g * [1, 1, 1e3], 2).tolist(),
            "final best lineage",
            np.round(b * [1, 1, 1e3], 2).tolist(),
            "population sd",
            np.round(sd * [1, 1, 1e3], 2).tolist(),
            "nearest particle %.2f" % np.hypot(p[:, 0], p[:, 1]).min(),
            "ancestors at mid lap 1",
            np.unique(up).size,
            "resamplings lap 1 / 2",
            int(z["resampled"][first].sum()),
            int(z["resampled"][~first].sum()),
        )


if __name__ == "__main__":
    main()
