"""An online adaptive EKF-SLAM, tried and not kept (research/notebook/2026-11-28-ekf-adaptive-noise.md, script O):
R scaled by Sage–Husa's posterior covariance matching over KR matched rows, Q by the windowed correction statistic over
WQ sets, each only when its window rejects the model at conf.

    python research/scripts/ekf_adaptive_noise_O.py victoria_park '{"WQ": 20, "KR": 50, "conf": 0.999, "R": 1, "Q": 1}' ['{EKF-SLAM parameters}']
"""

import json
import runpy
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from slamarena.datasets.geometry import wrap_angle
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam import association as assoc


def main() -> None:
    name = sys.argv[1]
    cfg = json.loads(sys.argv[2])
    params = json.loads(sys.argv[3]) if len(sys.argv) > 3 else {}
    WQ, KR, conf = cfg.get("WQ", 20), cfg.get("KR", 50), cfg.get("conf", 0.999)
    seq = runpy.run_path(str(Path(__file__).with_name("ekf_adaptive_noise_W.py")))["sequence"](name)  # script W's

    class A(EKFSLAM):
        def reset(self, sequence=None):
            super().reset(sequence)
            self.rq, self.rr = 1.0, 1.0
            self.c, self.V, self.nsets = np.zeros(3), np.zeros((3, 3)), 0
            self.rows_nis, self.rows_r = [], []
            self.trace = []

        def _chain(self, delta, Q_body, Q_world, true_poses, anchor_shift=None):
            if Q_body is not None and len(Q_body):
                Q_body = np.asarray(Q_body) * self.rq
            return super()._chain(delta, Q_body, Q_world, true_poses, anchor_shift)

        def update(self, z, t=None, decide=None, R=None):
            z = np.asarray(z, float)
            if R is None:
                R = self.observation_cov(z)
            R = np.asarray(R)
            x0, P0 = self.x[:3].copy(), self.robot_cov
            n0 = len(self.assoc_log)
            k0 = len(self.nis_log)
            super().update(z, t, decide, R * self.rr)
            log = self.assoc_log[n0:]
            dec = np.array([l[0] for l in log])
            lid = [l[1] for l in log]
            m = np.flatnonzero(dec == 0)
            if len(log) != len(z):
                return
            if m.size:
                slots = np.array([self._slot[lid[j]] for j in m])
                zhat, B = assoc.innovation_cov(self._s.x, self._s.view, slots)
                e = z[m, :2] - zhat
                e[:, 1] = wrap_angle(e[:, 1])
                Ri = np.linalg.inv(R[m])
                r = (np.einsum("ki,kij,kj->k", e, Ri, e) + np.einsum("kij,kji->k", Ri, B)) / 2
                self.rows_r += r.tolist()
                self.rows_nis += [v for v, _ in self.nis_log[k0:]]
                d = self.x[:3] - x0
                d[2] = wrap_angle(d[2])
                self.c += d
                self.V += P0 - self.robot_cov
                self.nsets += 1
            if len(self.rows_r) >= KR:
                s = sum(self.rows_nis)
                if s < chi2.ppf(1 - conf, 2 * len(self.rows_nis)) or s > chi2.ppf(conf, 2 * len(self.rows_nis)):
                    self.rr = max(float(np.mean(self.rows_r)), 1e-6) if cfg.get("R", 1) else self.rr
                self.rows_r, self.rows_nis = [], []
            if self.nsets >= WQ:
                T = float(self.c @ np.linalg.solve(self.V, self.c)) if np.linalg.det(self.V) > 0 else 0.0
                if cfg.get("Q", 1) and (T > chi2.ppf(conf, 3) or (cfg.get("down", 0) and T < chi2.ppf(1 - conf, 3))):
                    self.rq = max(1.0, self.rq * T / 3)
                self.c, self.V, self.nsets = np.zeros(3), np.zeros((3, 3)), 0
            self.trace.append((t, self.rr, self.rq))

    ekf = A(**{"use_ids": False, "window": 0, **params})
    est = ekf.run(seq)
    tr = np.array(ekf.trace)
    out = f"{name} {cfg}: landmarks {len(est.landmark_ids)}, m/n/r {est.meta['matched']}/{est.meta['new']}/{est.meta['rejected']}, final rr {tr[-1, 1]:.3g} rq {tr[-1, 2]:.3g}; rq max {tr[:, 2].max():.3g}, rr min/max {tr[:, 1].min():.3g}/{tr[:, 1].max():.3g}"
    if name == "victoria_park":
        out += f", end {np.linalg.norm(est.poses[-1][:2] - [-13.99, 0.53]):.1f} m from iSAM2"
    if seq.ground_truth is not None:
        from slamarena.experiments.metrics import reference_of
        from slamarena.experiments.metrics.trajectory import ATEParams, ate

        out += f", ATE {ate(est, reference_of(seq), ATEParams(align='se2', max_gap=0.25))[0]['rmse']:.3f}"
    print(out)
    ch = np.flatnonzero(np.diff(tr[:, 2]) != 0)
    print("rq changes:", [(tr[i + 1, 0], round(tr[i + 1, 2], 1)) for i in ch][:15])


if __name__ == "__main__":
    main()
