"""notebook/2026-11-23-fastslam-victoria-park-no-ids.md, script D (D (the row without the rule))

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_D.py fastslam_no_ids_identified 0 '{"confirm_sightings": 1}' 1130 1420``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.estimators.fastslam import FastSLAM
from slamarena.experiments.config import load_config


def main() -> None:
    label, seed, extra, centres = sys.argv[1], int(sys.argv[2]), eval(sys.argv[3]), [float(a) for a in sys.argv[4:]]
    seq = datasets.load("victoria_park")
    rb = seq.range_bearing
    isam = Estimate.load("results/victoria_park/runs/victoria_park/gtsam_isam2/0/estimate.npz")
    spec = {(e.label or e.name): e for e in load_config("victoria_park").estimators}
    err = lambda e, ref: np.hypot(
        *(e.poses[:, :2] - interpolate_poses(ref.t, ref.poses, np.clip(e.t, ref.t[0], ref.t[-1]))[:, :2]).T
    )
    withids = FastSLAM(**{**spec["fastslam_identified"].resolved_params(), "seed": seed}).run(seq)
    slam = FastSLAM(**{**spec[label].resolved_params(), "seed": seed, **extra})
    XY = np.full((10**4, 2), np.nan)
    XY[isam.landmark_ids] = isam.landmarks  # iSAM2's trees by label
    stamps = {g: rb.t[rb.landmark_id == g] for g in np.unique(rb.landmark_id)}
    RARE = np.zeros(10**4, dtype=bool)  # labels never seen 3 times within 10 s (the EKF's rule)
    for g, ts in stamps.items():
        RARE[g] = not np.any(ts[2:] - ts[:-2] <= 10.0) if ts.size >= 3 else True
    print("rare labels", RARE.sum(), "of", len(stamps))
    lab = np.full((slam.M, 4096), -1, dtype=np.int64)  # the label of the row that started each slot, per particle
    rec = []

    def update(z, *a, update=slam.update):
        z = np.asarray(z, float).reshape(-1, 3)
        n0 = slam.n_slots.copy()
        nb = slam.n_eff
        assoc = update(z, *a)
        w = np.exp(slam.last_log_w - slam.last_log_w.max())
        w /= w.sum()
        best = int(np.argmax(w))
        g = z[:, 2].astype(np.int64)
        M, k = assoc.shape
        new = assoc >= n0[:, None]
        for m in range(M):
            for j in range(k):
                if new[m, j]:
                    lab[m, assoc[m, j]] = g[j]
        src = lab[np.arange(M)[:, None], np.maximum(assoc, 0)]  # the label that started the matched slot
        right = (
            ~new & (assoc >= 0) & (np.hypot(*(XY[src] - XY[g][None]).transpose(2, 0, 1)) < 1.5)
        )  # the same tree in iSAM2's map
        onrare = ~new & (assoc >= 0) & ~right & RARE[src]  # a wrong match to a landmark started by a rarely seen tree
        dup = new & np.array(
            [[bool(np.any(np.hypot(*(XY[lab[m, : n0[m]]] - XY[g[j]]).T) < 1.5)) for j in range(k)] for m in range(M)]
        )
        rec.append(
            dict(
                onrare=onrare,
                g=g,
                best=best,
                w=w,
                nb=nb,
                na=1 / np.sum(w**2),
                new=new,
                right=right,
                dup=dup,
                assoc=assoc,
                anc=slam.last_ancestors,
                live=slam.n_live.copy(),
            )
        )
        if slam.last_ancestors is not None:
            lab[:] = lab[slam.last_ancestors]
        return assoc

    slam.update = update
    est = slam.run(seq)
    T = np.unique(rb.t)
    e_ids, e_isam, ids_isam = err(est, withids), err(est, isam), err(withids, isam)
    print(
        f"{label} {extra} seed {seed}: landmarks {len(est.landmarks)}; vs iSAM2 {np.sqrt(np.mean(e_isam**2)):.1f}/{e_isam.max():.1f}/{e_isam[-1]:.1f}; "
        f"> 1 / 5 / 20 m from the ids run first at t = {[float(est.t[np.argmax(e_ids > x)]) for x in (1, 5, 20)]}, from iSAM2 "
        f"{[float(est.t[np.argmax(e_isam > x)]) for x in (1, 5, 20)]}; ids run from iSAM2 {[float(withids.t[np.argmax(ids_isam > x)]) for x in (1, 5, 20)]}"
    )
    rows = np.array([r["g"].size for r in rec])
    for a in range(0, 7000, 500):  # per stretch: weighted fractions of the rows, the heaviest particle's, N_eff
        u = np.flatnonzero((T >= a) & (T < a + 500))
        f = lambda key: sum((rec[i]["w"] @ rec[i][key].sum(axis=1)) for i in u) / max(rows[u].sum(), 1)
        wrong = sum(rec[i]["w"] @ (~rec[i]["new"] & ~rec[i]["right"]).sum(axis=1) for i in u) / max(rows[u].sum(), 1)
        hb = lambda key: sum(rec[i][key][rec[i]["best"]].sum() for i in u) / max(rows[u].sum(), 1)
        hw = sum((~rec[i]["new"][rec[i]["best"]] & ~rec[i]["right"][rec[i]["best"]]).sum() for i in u) / max(
            rows[u].sum(), 1
        )
        na = np.array([rec[i]["na"] for i in u])
        wr = sum(rec[i]["w"] @ rec[i]["onrare"].sum(axis=1) for i in u) / max(rows[u].sum(), 1)
        s = (est.t >= a) & (est.t < a + 500)
        print(
            f" {a}-{a + 500}: rows {rows[u].sum()} | weighted new {f('new'):.2f} (dup {f('dup'):.2f}) right {f('right'):.2f} wrong {wrong:.2f} "
            f"(to a rare tree's {wr:.2f}) | heaviest new {hb('new'):.2f} (dup {hb('dup'):.2f}) right {hb('right'):.2f} wrong {hw:.2f}"
            f" | N_eff after median {np.median(na):.1f}, <2 in {np.sum(na < 2)} | live mean {np.mean([rec[i]['live'].mean() for i in u]):.0f} "
            f"| err vs ids max {e_ids[s].max():.1f} vs iSAM2 max {e_isam[s].max():.1f}"
        )
    sxy = np.sqrt(np.trace(est.pose_cov[:, :2, :2], axis1=1, axis2=2))
    for i in np.flatnonzero(
        np.any([(T >= c - 40) & (T <= c + 15) for c in centres], axis=0)
    ):  # every update near the given steps
        r = rec[i]
        b = r["best"]
        dec = [
            "N" + ("d" if r["dup"][b, j] else "")
            if r["new"][b, j]
            else ("m" if r["right"][b, j] else f"W{r['assoc'][b, j]}")
            for j in range(r["g"].size)
        ]
        print(
            f"  t {T[i]:.0f}: ids {r['g'].tolist()} heaviest {dec} | weighted right {r['w'] @ r['right'].mean(1):.2f} new {r['w'] @ r['new'].mean(1):.2f} "
            f"| N_eff {r['nb']:.1f} -> {r['na']:.1f}{' R' if r['anc'] is not None else ''} | err vs ids {np.interp(T[i], est.t, e_ids):.1f} "
            f"vs iSAM2 {np.interp(T[i], est.t, e_isam):.1f} σ_xy {np.interp(T[i], est.t, sxy):.1f}"
        )


if __name__ == "__main__":
    main()
