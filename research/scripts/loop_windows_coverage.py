"""notebook/2026-11-28-loop-windows.md: do windows from the sequential factors' covariance cover the front end's drift?

Run from the repository root: ``python research/scripts/loop_windows_coverage.py SEEDS [key=value ...]`` (laser_slam
parameters as ``slamarena map`` takes them; loop closure is switched off: the chain alone). On the ``loop_closure``
drive (``loop_verification_long_loop.DRIVE``) every node's inputs to its sequential factor's covariance are recorded
(the match's covariance C and information I, the interval's odometry covariance Q with the drive's own noise), and
for several covariance rules, for node pairs (p, q) m nodes apart, the chain's relative pose T_pq = L_p⁻¹ L_q is
compared with the truth: NEES eᵀ P⁻¹ e of e = Log(T_pq⁻¹ X_p⁻¹ X_q) and whether the loop search's window
(± κ √λ_max(P[:2, :2]) and ± κ √P[2, 2], κ² = χ²₃(0.999)) holds the error. Prints per rule and m the median NEES
and the fraction covered.
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.stats import chi2

from slamarena.datasets.geometry import between, se2_log
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.cli_map import parse_params
from slamarena.mapping.laser_slam.consistency import OdometryChain
from slamarena.mapping.laser_slam.interval import OdometryNoiseParams, fuse
from slamarena.mapping.laser_slam.slam import LaserSLAM, _rotation

sys.path.insert(0, "research/scripts")
from loop_verification_long_loop import DRIVE  # noqa: E402

#: the drive's own odometry noise (k_s: the simulator's default 0.01)
NOISE = OdometryNoiseParams(k_t=DRIVE["k_t"], k_s=0.01, k_r=DRIVE["k_r"], k_rt=DRIVE["k_rt"])
FLOOR = np.diag(np.square([0.02, 0.02, 0.005]))
SPANS = (10, 30, 100, 300)


def disagreement(z: np.ndarray, u: np.ndarray, Q: np.ndarray, C: np.ndarray) -> float:
    """d² = eᵀ (Q + C)⁻¹ e of the front end's relative pose z (3,) against the odometry's u (3,) over the same interval,
    e = Log(u⁻¹ z) in the interval's end frame, Q and C (3, 3) their covariances there; 0 when Q is undefined (NaN)."""
    if not np.all(np.isfinite(Q)):
        return 0.0
    e = se2_log(between(u, z))
    return float(e @ np.linalg.solve(Q + C, e))


class _Recording(LaserSLAM):
    def _add_to_graph(self, run, i, k):
        self.rec.append((run.L[i].copy(), run.match_cov[k].copy(), run.match_info[k].copy(), run.odo_cov[k].copy(), k))
        super()._add_to_graph(run, i, k)


def rules(rec, odometry) -> dict[str, np.ndarray]:
    """Per node i ≥ 1, the sequential factor's covariance (N − 1, 3, 3) under each rule."""
    out = {"match": [], "interval": [], "match x d2": [], "interval x d2": [], "odometry": []}
    for (L0, *_, k0), (L1, C, info, Q, k1) in zip(rec[:-1], rec[1:]):
        R = _rotation(L1[2])
        match = R.T @ C @ R
        interval = fuse(Q, R.T @ info @ R)
        inflate = max(1.0, disagreement(between(L0, L1), between(odometry[k0], odometry[k1]), Q, match + FLOOR) / 3.0)
        out["match"].append(match + FLOOR)
        out["interval"].append(interval + FLOOR)
        out["match x d2"].append(inflate * match + FLOOR)
        out["interval x d2"].append(inflate * interval + FLOOR)
        out["odometry"].append(Q + FLOOR)
    return {name: np.asarray(v) for name, v in out.items()}


def coverage(L: np.ndarray, X: np.ndarray, covs: np.ndarray, span: int, kappa: float) -> tuple[float, float]:
    chain = OdometryChain()
    chain.add(L[0], None)
    for pose, cov in zip(L[1:], covs):
        chain.add(pose, cov)
    p = np.arange(0, len(L) - span)
    q = p + span
    T, P = chain.relative(p, q)
    e = se2_log(between(T, between(X[p], X[q])))
    nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(P), e)
    lin = kappa * np.sqrt(np.linalg.eigvalsh(P[:, :2, :2])[:, -1])
    ang = kappa * np.sqrt(P[:, 2, 2])
    covered = (np.hypot(e[:, 0], e[:, 1]) <= lin) & (np.abs(e[:, 2]) <= ang)
    return float(np.median(nees)), float(covered.mean())


def main() -> None:
    seeds = [int(s) for s in sys.argv[1].split(",")]
    params = parse_params(sys.argv[2:])
    params.setdefault("loop", {})["enabled"] = False
    params["odometry_noise"] = NOISE.model_dump()
    kappa = float(np.sqrt(chi2.ppf(0.999, 3)))
    for seed in seeds:
        seq = simulate(seed=seed, **DRIVE)
        slam = _Recording(**params)
        slam.rec = []
        slam.run(seq)
        gt = seq.ground_truth
        truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
        nodes = [r[4] for r in slam.rec]
        L = np.asarray([r[0] for r in slam.rec])
        for name, covs in rules(slam.rec, seq.scans.pose).items():
            cells = [coverage(L, truth[nodes], covs, m, kappa) for m in SPANS]
            text = ", ".join(f"m={m}: NEES {n:.1f} covered {c:.2f}" for m, (n, c) in zip(SPANS, cells))
            print(f"seed {seed} {name:>14}: {text}", flush=True)


if __name__ == "__main__":
    main()
