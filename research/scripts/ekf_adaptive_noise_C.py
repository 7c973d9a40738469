"""The robot's correction statistic T = cᵀV⁻¹c (χ²₃ under a correct model) over windows ending before Victoria Park's
first loop closure (research/notebook/2026-11-28-ekf-adaptive-noise.md, script C).

    python research/scripts/ekf_adaptive_noise_C.py '{EKF-SLAM parameters}'
"""

import json
import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.geometry import wrap_angle
from slamarena.estimators.ekf_slam import EKFSLAM


def main() -> None:
    seq = datasets.load("victoria_park")
    params = json.loads(sys.argv[1])

    class A(EKFSLAM):
        def update(self, z, t=None, decide=None, R=None):
            x0, P0 = self.x[:3].copy(), self.robot_cov
            super().update(z, t, decide, R)
            d = self.x[:3] - x0
            d[2] = wrap_angle(d[2])
            rec.append((t, *d, *(P0 - self.robot_cov).ravel()))

    rec = []
    ekf = A(use_ids=False, window=0, **params)
    est = ekf.run(seq)
    r = np.array(rec)
    t = r[:, 0]
    for W in (10, 20, 40, 80):
        for end in (60, 100, 140, 160, 200):
            sel = (t <= end) & (t > end - W * 2)
            c = r[sel, 1:4].sum(0)
            V = r[sel, 4:].sum(0).reshape(3, 3)
            print(W, end, "sets", sel.sum(), "T3 %.1f" % (c @ np.linalg.solve(V, c)), "Tθ %.1f" % (c[2] ** 2 / V[2, 2]))


if __name__ == "__main__":
    main()
