"""notebook/2026-11-23-ekf-slam-victoria-park.md, script NS (NS)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_NS.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np
from scipy.stats import chi2

from slamarena.datasets.estimate import Estimate


def main() -> None:
    for lab in ["ekf_slam_identified", "ekf_slam_nn_managed", "ekf_slam_jcbb_managed"]:
        e = Estimate.load(f"results/victoria_park/runs/victoria_park/{lab}/0/estimate.npz")
        q = np.asarray(e.diagnostics["nis"]) / np.asarray(e.diagnostics["nis_dof"])
        d = np.asarray(e.diagnostics["nis"])
        inside = d < chi2.ppf(0.95, 2)
        print(
            f"{lab}: rows {q.size}, NIS/dof mean {q.mean():.3f}, median {np.median(q):.3f} (χ²₂/2: 0.693), "
            f"mean of rows with d² < 5.99 {q[inside].mean():.3f} (χ²₂ truncated there: 0.843), "
            f"share beyond χ²₂(0.95) {1 - inside.mean():.3f}, beyond χ²₂(0.999) {(d > chi2.ppf(0.999, 2)).mean():.3f}"
        )


if __name__ == "__main__":
    main()
