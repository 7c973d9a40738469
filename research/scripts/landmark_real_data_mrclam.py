"""EKF-SLAM (standard, FEJ, OC), FastSLAM and dead reckoning with the shipped mrclam parameters on one MRCLAM dataset:
ATE against a reference trajectory, map error (aligned on the surveyed landmarks), rows rejected and the longest lock-out
(research/notebook/2026-11-28-landmark-real-data.md).

    python research/scripts/landmark_real_data_mrclam.py DATASET [robot ...] [--methods a,b] [--param key=value ...]

Dataset 6 is scored against Vicon. Dataset 1 has no robot ground truth (utias_mrclam/SOURCE.md): its reference is
the GTSAM batch smoother with the shipped parameters (ATE 0.115-0.202 m against Vicon on Dataset 6; it converges on
Dataset 1: research/notebook/2026-11-28-gtsam-convergence.md), written to /tmp so that it is computed once. (The
EKF localizer is no reference there: Dataset 1's surveyed positions of landmarks 11 and 17 are swapped against the
barcodes, ≈ 6 m apart after alignment, and its map is the surveyed one.)
"""

import argparse
import os
import time

import numpy as np

from slamarena.datasets.registry import load
from slamarena.estimators import create
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.reference import Reference
from slamarena.experiments.metrics.trajectory import ATEParams, ate

NOISE = dict(twist_cov=[0.0117624, 0.174], range_bearing_cov=[0.0225, 0.0004])
METHODS = {
    "dead_reckoning": ("dead_reckoning", {}),
    "ekf_slam": ("ekf_slam", dict(NOISE, known_confidence=0.999)),
    "ekf_slam_fej": ("ekf_slam", dict(NOISE, known_confidence=0.999, jacobians="fej", anchor_confidence=0.99999)),
    "ekf_slam_oc": ("ekf_slam", dict(NOISE, known_confidence=0.999, jacobians="oc", anchor_confidence=0.99999)),
    "fastslam": ("fastslam", dict(NOISE, version=2, particles=50)),
    "fastslam1": ("fastslam", dict(NOISE, version=1, particles=50)),
}
SWAPPED = {"1": [11, 17]}  # surveyed positions swapped against the barcodes (left out of the map error)
SMOOTHER = dict(NOISE, robust="huber", max_interval=1.0, max_iterations=500)


def reference(seq, dataset: str, robot: int) -> Reference:
    ref = reference_of(seq)
    if ref.t is not None:
        return ref
    cache = f"/tmp/mrclam_D{dataset}_robot{robot}_batch.npz"
    if not os.path.exists(cache):
        est = create("gtsam_batch", **SMOOTHER).run(seq)
        np.savez(cache, t=est.t, poses=est.poses)
    r = np.load(cache)
    return Reference(r["t"], r["poses"], ref.landmark_ids, ref.landmarks, ref.observed_ids)


def value(text: str):
    try:
        return float(text) if "." in text or "e" in text else int(text)
    except ValueError:
        return None if text == "null" else text


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("robots", nargs="*", type=int, default=[1, 2, 3, 4, 5])
    ap.add_argument("--methods", default="dead_reckoning,ekf_slam,ekf_slam_fej,ekf_slam_oc")
    ap.add_argument("--param", action="append", default=[], help="key=value added to every EKF-SLAM / FastSLAM row")
    a = ap.parse_args()
    extra = {k: value(v) for k, v in (p.split("=", 1) for p in a.param)}
    for k in a.robots:
        seq = load("utias", path=f"utias_mrclam/MRCLAM_Dataset{a.dataset}", robot=k)
        ref = reference(seq, a.dataset, k)
        truth = reference_of(seq)
        keep = ~np.isin(truth.landmark_ids, SWAPPED.get(a.dataset, []))
        map_ref = Reference(
            None, None, truth.landmark_ids[keep], truth.landmarks[keep], None
        )  # aligned on the landmarks
        for label in a.methods.split(","):
            name, params = METHODS[label]
            params = dict(params, **(extra if name != "dead_reckoning" else {}))
            tic = time.process_time()
            est = create(name, **params).run(seq)
            cpu = time.process_time() - tic
            score, _ = ate(est, ref, ATEParams(align="se2", max_gap=0.05))
            d = est.diagnostics or {}
            try:
                m = landmark_error(est, map_ref, MapParams(by="id", align="se2"))[0]["rmse"]
            except Exception:
                m = float("nan")
            rej = int((d["assoc_decision"] == 2).sum()) if "assoc_decision" in d else 0
            print(
                f"D{a.dataset} robot{k} {label:15s} ATE {score['rmse']:.3f} max {score['max']:.2f} map {m:.3f} "
                f"lockout {int(d.get('lockout_rows', 0))} rows / {float(d.get('lockout_s', 0)):.0f} s "
                f"at {float(d.get('lockout_t0', np.nan)):.0f}  gated {rej}  anchors reset {(est.meta or {}).get('anchors_reset', 0)}  cpu {cpu:.0f} s",
                flush=True,
            )


if __name__ == "__main__":
    main()
