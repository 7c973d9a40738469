"""The windowed correction statistic T = c²/V of the heading (c: the robot's heading corrections summed over W update
sets, V: the summed reductions of its variance; χ²₁ under a correct model) on a run without ids
(research/notebook/2026-11-28-ekf-adaptive-noise.md, script W).

    python research/scripts/ekf_adaptive_noise_W.py victoria_park|carpark|sim0 ['{EKF-SLAM parameters}']
"""

import json
import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.geometry import wrap_angle
from slamarena.estimators import create


def sequence(name: str):
    """The landmark sequence a name stands for (shared by scripts G and O): ``carpark`` (beacons extracted from the raw
    scans), ``simK`` (the 50-landmark world, two laps, seed K) or a dataset name."""
    if name == "carpark":
        from slamarena.mapping.landmark_extraction import landmark_sequence

        return landmark_sequence(datasets.load("carpark"))
    if name.startswith("sim"):
        return datasets.load("sim:landmarks", n_landmarks=50, laps=2, seed=int(name[3:] or 0))
    return datasets.load(name)


def main() -> None:
    name = sys.argv[1]
    params = json.loads(sys.argv[2]) if len(sys.argv) > 2 else {}
    seq = sequence(name)
    ekf = create("ekf_slam", **{"use_ids": False, "window": 0, **params})
    rec = []
    orig = ekf.update

    def upd(z, t, decide=None, R=None):
        x0, P0 = ekf.x[:3].copy(), ekf.robot_cov.copy()
        orig(z, t, decide, R)
        rec.append(
            (
                t,
                wrap_angle(ekf.x[2] - x0[2]),
                *(ekf.x[:2] - x0[:2]),
                P0[2, 2] - ekf.robot_cov[2, 2],
                P0[0, 0] + P0[1, 1] - ekf.robot_cov[0, 0] - ekf.robot_cov[1, 1],
            )
        )

    ekf.update = upd
    est = ekf.run(seq)
    r = np.array(rec)
    print(name, "sets", len(r), "landmarks", len(est.landmark_ids))
    for W in (10, 20, 50):
        c = np.convolve(r[:, 1], np.ones(W), "valid")
        V = np.convolve(r[:, 4], np.ones(W), "valid")
        T = c**2 / np.maximum(V, 1e-300)
        print(
            f"W={W}: heading T mean {T.mean():.2f} median {np.median(T):.2f} p95 {np.percentile(T, 95):.1f} frac>chi2_1(.99999)={np.mean(T > 19.5):.3f} first>19.5 at set {np.argmax(T > 19.5) if (T > 19.5).any() else -1} t={r[np.argmax(T > 19.5), 0] if (T > 19.5).any() else -1}"
        )


if __name__ == "__main__":
    main()
