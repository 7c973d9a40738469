"""The GTSAM smoothers on the ACFR Car Park (research/notebook/2026-11-28-carpark.md). They take labelled observations
only, so their labels here are EKF-SLAM's own association (the config's ``ekf_slam_jcbb`` row: the car park's motion
noise and tentative landmarks, JCBB): each extracted row gets the id of the landmark the filter matched or created,
rows it rejected or whose landmark it removed are dropped. The smoothers then run with their defaults and with the
car park's motion noise; scored as the config scores (ATE against GPS, SE(2); the map against the surveyed beacons).

    python research/scripts/carpark_smoothers.py
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

import slamarena
from slamarena import datasets
from slamarena.datasets.sequence import RangeBearing
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.landmark_extraction import landmark_sequence

MOTION = {"twist_cov": [[0.16, 0.0], [0.0, 0.04]]}  # &carpark_motion of experiments/configs/carpark.yaml
FRONT_END = {**MOTION, "confirm_sightings": 3, "confirm_window": 2.0, "use_ids": False, "association": "jcbb"}


def score(est, ref) -> str:
    trajectory, _ = ate(est, ref, ATEParams(align="se2", max_gap=0.25))
    line = f"ATE {trajectory['rmse']:.3f} m"
    if est.landmarks is not None and len(est.landmarks):
        m, _ = landmark_error(est, ref, MapParams(by="nearest", max_distance=2.0, max_gap=0.25))
        line += f", {len(est.landmark_ids)} landmarks, map RMS {m['rmse']:.3f} m, matched {m['matched']}, spurious {m['spurious']}"
    return line


def main() -> None:
    seq = landmark_sequence(datasets.load("carpark"))
    ref = reference_of(seq)
    ekf = slamarena.create("ekf_slam", **FRONT_END).run(seq)
    print(f"front end, EKF-SLAM (JCBB): {score(ekf, ref)}")
    d = ekf.diagnostics
    rb = seq.range_bearing
    if not np.allclose(d["assoc_t"], rb.t):
        raise RuntimeError("the filter's association log is not one decision per extracted row")
    ids = np.where(d["assoc_decision"] == 2, -1, d["assoc_landmark"])
    keep = np.isin(ids, ekf.landmark_ids)  # rejected rows and landmarks the filter removed (tentative) are dropped
    print(f"labelled rows: {keep.sum()} of {len(rb)} ({len(np.unique(ids[keep]))} landmarks)")
    labelled = replace(
        seq,
        range_bearing=RangeBearing(t=rb.t[keep], range=rb.range[keep], bearing=rb.bearing[keep], landmark_id=ids[keep]),
    )
    for name in ("gtsam_isam2", "gtsam_batch"):
        for label, params in (("defaults", {}), ("car park motion noise", MOTION)):
            try:
                est = slamarena.create(name, **params).run(labelled)
                print(f"{name}, {label}: {score(est, ref)}")
            except Exception as exc:  # a failed optimisation is reported, not scored
                print(f"{name}, {label}: {type(exc).__name__}: {str(exc)[:300]}")


if __name__ == "__main__":
    main()
