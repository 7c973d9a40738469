"""notebook/2026-11-23-ekf-slam-victoria-park.md, script A (A: diagnosis with ids)

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_A.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import numpy as np

from slamarena import datasets, estimators
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    rb = seq.range_bearing
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    isam2 = estimators.create("gtsam_isam2", **spec["gtsam_isam2"].resolved_params()).run(seq)
    L = dict(zip(isam2.landmark_ids.tolist(), isam2.landmarks))
    ids = np.array(list(L))
    xy = np.array(list(L.values()))
    for jac in ("standard", "oc", "fej"):  # (a) the config's ekf_slam row (ids, ungated), three linearisations
        est = estimators.create("ekf_slam", **{**spec["ekf_slam"].resolved_params(), "jacobians": jac}).run(seq)
        nis, t = est.diagnostics["nis"], est.diagnostics["nis_t"]
        print(
            jac,
            nis[t < 413].mean() / 2,
            (t < 413).sum(),
            nis[t == 413],
            np.hypot(*(est.poses[-1, :2] - isam2.poses[-1, :2])),
        )
    for k in range(len(rb.t)):  # (b) each row against iSAM2's pose and map (σ² 0.4)
        p = isam2.poses[int(rb.t[k])]
        w = p[:2] + rb.range[k] * np.array([np.cos(p[2] + rb.bearing[k]), np.sin(p[2] + rb.bearing[k])])
        own = np.hypot(*(w - L[int(rb.landmark_id[k])]))
        d = np.hypot(*(xy - w).T)
        if own**2 / 0.4 > 23.03:
            print(rb.t[k], rb.landmark_id[k], own**2 / 0.4, own, ids[d.argmin()], d.min())
    D = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
    np.fill_diagonal(D, np.inf)
    scans = {}
    for t, g in zip(rb.t, rb.landmark_id):
        scans.setdefault(t, set()).add(int(g))
    for a, b in zip(*np.nonzero(np.triu(D < 1.0))):  # one tree, two ids?
        A, B = int(ids[a]), int(ids[b])
        print(A, B, D[a, b], sum(A in s and B in s for s in scans.values()))
    r = seq.motion.delta[:, 2] - np.angle(
        np.exp(1j * np.diff(isam2.poses[:, 2]))
    )  # odometry heading vs the smoothed poses
    print(r.mean(), r.std(), np.convolve(r, np.ones(200) / 200, "valid").min())


if __name__ == "__main__":
    main()
