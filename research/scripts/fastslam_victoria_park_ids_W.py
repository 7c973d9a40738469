"""notebook/2026-11-23-fastslam-victoria-park-ids.md, script W (W)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_ids_W.py 0 1 2``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np
from scipy.stats import chi2

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.fastslam.kernels import predictive_d2
from slamarena.experiments.config import load_config


def main() -> None:
    seq = datasets.load("victoria_park")
    rb = seq.range_bearing
    g = chi2.ppf(0.99999, 2)
    runs = "results/victoria_park/runs/victoria_park"
    isam, ekf = (Estimate.load(f"{runs}/{n}/0/estimate.npz") for n in ("gtsam_isam2", "ekf_slam_identified"))
    err = lambda e: np.hypot(
        *(e.poses[:, :2] - interpolate_poses(isam.t, isam.poses, np.clip(e.t, isam.t[0], isam.t[-1]))[:, :2]).T
    )
    L = dict(zip(isam.landmark_ids.tolist(), isam.landmarks))
    print("EKF: labelled rows beyond χ²₂(0.99999):", np.sum(ekf.diagnostics["nis"] > g))
    sxy = lambda e: np.sqrt(np.trace(e.pose_cov[:, :2, :2], axis1=1, axis2=2))
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[
        "fastslam_identified"
    ].resolved_params()
    for seed in map(int, sys.argv[1:]):
        slam, rec = FastSLAM(**{**params, "seed": seed}), []

        def update(z, update=slam.update):  # d² of every labelled row in every particle, before the update
            z = np.asarray(z, float).reshape(-1, 3)
            xhat, P = slam.predicted()
            slots = np.array([slam._slot_of_id.get(int(i), 10**9) for i in z[:, 2]], dtype=np.int64)
            d2 = predictive_d2(
                xhat,
                P,
                np.ascontiguousarray(z[:, :2]),
                slots,
                slam.n_slots,
                slam._noise(z),
                slam.store.depth,
                slam.store.roots,
                slam.store.inner_child,
                slam.store.leaf_mu,
                slam.store.leaf_S,
            )
            n_before = slam.n_eff
            out = update(z)
            w = np.exp(slam.last_log_w - slam.last_log_w.max())
            w /= w.sum()
            rec.append((d2, n_before, 1 / np.sum(w**2), slam.last_ancestors))
            return out

        slam.update = update
        est = slam.run(seq)
        ef, ee = err(est), err(ekf)
        T = np.unique(seq.range_bearing.t)
        n_after = np.array([r[2] for r in rec])
        worst = np.array([np.nanmax(np.nanmin(r[0], axis=0)) if np.isfinite(r[0]).any() else 0.0 for r in rec])

        def lineages(u, K=50):  # distinct ancestors, K updates back, of the particles after update u
            idx = np.arange(slam.M)
            for v in range(u, max(u - K, -1), -1):
                idx = idx if rec[v][3] is None else rec[v][3][idx]
            return np.unique(idx).size

        print(
            f"seed {seed}: RMSE / max / final vs iSAM2 {np.sqrt(np.mean(ef**2)):.1f} / {ef.max():.1f} (t = {est.t[ef.argmax()]:.0f}) / {ef[-1]:.1f}; "
            f"updates {len(rec)}, N_eff < 2 after {np.sum(n_after < 2)}, of them with a row beyond χ²₂(0.99999) in every particle "
            f"{np.sum((n_after < 2) & (worst > g))}; such rows in {np.sum(worst > g)} updates"
        )
        for a in range(0, 7000, 500):
            s, q, u = ((x >= a) & (x < a + 500) for x in (est.t, ekf.t, T))
            print(
                f"  {a}-{a + 500}: error max FastSLAM {ef[s].max():.1f} EKF {ee[q].max():.1f} | σ_xy median FastSLAM {np.median(sxy(est)[s]):.2f} "
                f"EKF {np.median(sxy(ekf)[q]):.2f} | distinct ancestors 50 updates back, max {max(lineages(k) for k in np.flatnonzero(u))}"
            )
        for t in (413, 4690, 4702, 4738, 4887, 4892, 5789, 5792, 5794):
            u = int(np.searchsorted(T, t))
            d2 = rec[u][0][:, 0]
            k = int(np.flatnonzero(rb.t == t)[0])
            p = isam.poses[np.searchsorted(isam.t, t)]
            off = np.hypot(
                *(
                    p[:2]
                    + rb.range[k] * np.array([np.cos(p[2] + rb.bearing[k]), np.sin(p[2] + rb.bearing[k])])
                    - L[int(rb.landmark_id[k])]
                )
            )
            print(
                f"  t = {t} (tree {rb.landmark_id[k]}, {off:.2f} m from iSAM2's tree; EKF NIS {ekf.diagnostics['nis'][ekf.diagnostics['nis_t'] == t]}, "
                f"error {np.interp(t - 2, ekf.t, ee):.1f} → {np.interp(t + 3, ekf.t, ee):.1f} m): d² min / median {d2.min():.1f} / {np.median(d2):.1f}; "
                f"N_eff {rec[u][1]:.1f} → {rec[u][2]:.1f}; error {np.interp(t - 2, est.t, ef):.1f} → {np.interp(t + 3, est.t, ef):.1f} m"
            )
        for a, b in ((5080, 5113), (5500, 6500)):  # rows beyond the bound in every particle (min over particles of d²)
            rows = [
                (T[u], int(i), np.nanmin(rec[u][0][:, j]))
                for u in np.flatnonzero((T >= a) & (T < b))
                for j, i in enumerate(seq.range_bearing.landmark_id[seq.range_bearing.t == T[u]][: rec[u][0].shape[1]])
                if np.isfinite(rec[u][0][:, j]).any()
            ]
            out = [r for r in rows if r[2] > g]
            print(
                f"  {a}–{b}: {len(out)} of {len(rows)} labelled rows beyond χ²₂(0.99999) in every particle, min d² {min((r[2] for r in out), default=0):.0f}–{max((r[2] for r in out), default=0):.0f}"
                + ("; " + ", ".join(f"{t:.0f}:{i}:{d:.0f}" for t, i, d in out) if b - a < 100 else "")
            )


if __name__ == "__main__":
    main()
