"""notebook/2026-11-23-fastslam-victoria-park-no-ids-round-4.md, script T (T (then 1 0 '{}'))

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_round_4_T.py 50 0 '{}'``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import pickle
import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.models import observation_covariances
from slamarena.experiments.config import load_config


def main() -> None:
    # T: where does FastSLAM without ids first depart from the EKF without ids, and on which rows
    M, seed, extra = int(sys.argv[1]), int(sys.argv[2]), eval(sys.argv[3])
    label = sys.argv[4] if len(sys.argv) > 4 else "fastslam_no_ids_identified"
    seq = datasets.load("victoria_park")
    rb = seq.range_bearing
    runs = "results/victoria_park/runs/victoria_park"
    isam, ekf = (Estimate.load(f"{runs}/{n}/0/estimate.npz") for n in ("gtsam_isam2", "ekf_slam_nn_managed"))
    XY = np.full((10**4, 2), np.nan)
    XY[isam.landmark_ids] = isam.landmarks
    same = lambda a, b: np.hypot(*(XY[a] - XY[b]).T) < 1.5 if np.ndim(a) else np.hypot(*(XY[a] - XY[b][None]).T) < 1.5
    # the EKF's decisions per row (rows in file order, as FastSLAM reads them)
    dg = ekf.diagnostics
    dec, lmk, gid = dg["assoc_decision"], dg["assoc_landmark"], dg["assoc_given_id"]
    ekf_lab = {}
    for d, l, g in zip(dec, lmk, gid):
        if d == 1:
            ekf_lab.setdefault(int(l), int(g))
    ekf_right = np.array(
        [d == 0 and bool(np.hypot(*(XY[ekf_lab.get(int(l), 0)] - XY[g])) < 1.5) for d, l, g in zip(dec, lmk, gid)]
    )
    params = {(e.label or e.name): e for e in load_config("victoria_park").estimators}[label].resolved_params()
    slam = FastSLAM(**{**params, "particles": M, "seed": seed, **extra})
    lab = np.full((M, 8192), -1, dtype=np.int64)
    rec = []
    row0 = [0]

    def d2_all(xhat, P, mu, S, z, R):
        """d² (M, n, k) of every row against every slot at the predicted pose: L = H_x P H_xᵀ + H_m Σ H_mᵀ + R_j."""
        dx, dy = mu[..., 0] - xhat[:, None, 0], mu[..., 1] - xhat[:, None, 1]
        q = dx**2 + dy**2
        r = np.sqrt(q)
        zh = np.stack([r, np.arctan2(dy, dx) - xhat[:, None, 2]], -1)
        Hm = np.stack([np.stack([dx / r, dy / r], -1), np.stack([-dy / q, dx / q], -1)], -2)
        Hx = np.stack([np.stack([-dx / r, -dy / r, 0 * r], -1), np.stack([dy / q, -dx / q, -1 + 0 * r], -1)], -2)
        Sig = np.stack([np.stack([S[..., 0], S[..., 1]], -1), np.stack([S[..., 1], S[..., 2]], -1)], -2)
        base = Hx @ P[:, None] @ np.swapaxes(Hx, -1, -2) + Hm @ Sig @ np.swapaxes(Hm, -1, -2)
        L = base[:, :, None] + R[None, None]  # (M, n, k, 2, 2)
        nu = z[None, None] - zh[:, :, None]
        nu[..., 1] = (nu[..., 1] + np.pi) % (2 * np.pi) - np.pi
        a, b, d = L[..., 0, 0], L[..., 0, 1], L[..., 1, 1]
        return (d * nu[..., 0] ** 2 - 2 * b * nu[..., 0] * nu[..., 1] + a * nu[..., 1] ** 2) / (a * d - b * b)

    def update(z, t=None, update=slam.update):
        z = np.asarray(z, float).reshape(-1, 3)
        k = len(z)
        rows = np.arange(row0[0], row0[0] + k)
        row0[0] += k
        n0 = slam.n_slots.copy()
        n = int(n0.max())
        xhat, P = slam.predicted()
        g = rb.landmark_id[rows].astype(np.int64)
        tru = np.full((M, k), np.inf)
        near = np.full((M, k), np.inf)
        if n:
            mu, S, state, seen, _ = slam.store.gather(n)
            d2 = d2_all(
                xhat, P, mu, S, z[:, :2], observation_covariances(slam.R, z[:, 0], slam.params.range_bearing_noise)
            )
            live = (state > 0) & (np.arange(n)[None] < n0[:, None])
            d2 = np.where(live[..., None], d2, np.inf)
            near = d2.min(1)
            for j in range(k):
                is_t = (
                    live
                    & (lab[:, :n] >= 0)
                    & (np.hypot(*(XY[np.maximum(lab[:, :n], 0)] - XY[g[j]]).transpose(2, 0, 1)) < 1.5)
                )
                tru[:, j] = np.where(is_t, d2[..., j], np.inf).min(1)
        assoc = update(z, t)
        w = np.exp(slam.last_log_w - slam.last_log_w.max())
        w /= w.sum()
        best = int(np.argmax(w))
        new = assoc >= n0[:, None]
        for m in range(M):
            for j in range(k):
                if new[m, j]:
                    lab[m, assoc[m, j]] = g[j]
        src = lab[np.arange(M)[:, None], np.maximum(assoc, 0)]
        right = ~new & (assoc >= 0) & (np.hypot(*(XY[src] - XY[g][None]).transpose(2, 0, 1)) < 1.5)
        dup = new & np.isfinite(tru)  # started although the particle had mapped the row's tree
        rec.append(
            dict(
                t=rb.t[rows[0]],
                rows=rows,
                w=w,
                best=best,
                new=new,
                right=right,
                dup=dup,
                tru=tru,
                near=near,
                matched_d2=np.where(~new & (assoc >= 0), near, np.nan),
            )
        )
        if slam.last_ancestors is not None:
            lab[:] = lab[slam.last_ancestors]
        return assoc

    slam.update = update
    est = slam.run(seq)
    err = lambda e, ref: np.hypot(
        *(e.poses[:, :2] - interpolate_poses(ref.t, ref.poses, np.clip(e.t, ref.t[0], ref.t[-1]))[:, :2]).T
    )
    e_ekf, e_isam, ekf_isam = err(est, ekf), err(est, isam), err(ekf, isam)
    first = lambda e, x: float(est.t[np.argmax(e > x)]) if np.any(e > x) else None
    print(
        f"M {M} seed {seed} {extra}: landmarks {len(est.landmark_ids)}; vs iSAM2 RMSE/max/final {np.sqrt(np.mean(e_isam**2)):.1f}/{e_isam.max():.1f}/{e_isam[-1]:.1f}; "
        f"vs EKF no ids: > 2 / 5 / 10 m first at t = {first(e_ekf, 2)} / {first(e_ekf, 5)} / {first(e_ekf, 10)}; EKF vs iSAM2 max {ekf_isam.max():.1f}"
    )
    T = np.array([r["t"] for r in rec])
    for a in range(0, 7000, 250):
        u = [i for i in range(len(rec)) if a <= T[i] < a + 250]
        if not u:
            continue
        R_ = np.concatenate([rec[i]["rows"] for i in u])
        b = [rec[i]["best"] for i in u]
        hb = lambda key: np.concatenate([rec[i][key][rec[i]["best"]] for i in u])
        wf = lambda key: sum((rec[i]["w"] @ rec[i][key]).sum() for i in u) / R_.size
        new_b, right_b, dup_b, tru_b, md2 = hb("new"), hb("right"), hb("dup"), hb("tru"), hb("matched_d2")
        em = dec[R_] == 0
        s = (est.t >= a) & (est.t < a + 250)
        print(
            f" {a:4d}-{a + 250}: rows {R_.size} | EKF matched {em.mean():.2f} (right {ekf_right[R_].mean():.2f}) new {np.mean(dec[R_] == 1):.2f} rej {np.mean(dec[R_] == 2):.2f}"
            f" | FS heaviest matched {np.mean(~new_b):.2f} (right {right_b.mean():.2f}) new {new_b.mean():.2f} dup {dup_b.mean():.2f}; weighted dup {wf('dup'):.2f}"
            f" | EKF matched & FS new {np.sum(em & new_b)} (true d² there median {np.median(tru_b[em & new_b]) if np.any(em & new_b) else np.nan:.0f})"
            f" | FS matched d²/2 mean {np.nanmean(md2) / 2:.2f} | err vs EKF max {e_ekf[s].max():.1f} vs iSAM2 {e_isam[s].max():.1f} (EKF {ekf_isam[(ekf.t >= a) & (ekf.t < a + 250)].max():.1f})",
            flush=True,
        )
    np.savez(f"T_{M}_{seed}.npz", t=est.t, e_ekf=e_ekf, e_isam=e_isam)
    pickle.dump(rec, open(f"T_{M}_{seed}.pkl", "wb"))


if __name__ == "__main__":
    main()
