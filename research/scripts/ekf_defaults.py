"""EKF-SLAM without ids (unless the JSON says use_ids), one parameter set per JSON argument, on Victoria Park and on the ACFR Car Park's extracted
beacons (research/notebook/2026-11-28-ekf-defaults.md): landmarks made, Victoria Park's final position against iSAM2's
with ids (−13.99, 0.53), the car park's ATE against GPS and map against the surveyed beacons (scored as the carpark
config scores), the decisions and the CPU time.

    python research/scripts/ekf_defaults.py [--data vp,carpark] '{}' '{"robust_update": "huber"}'
"""

import argparse
import json
import time

import numpy as np

from slamarena import datasets
from slamarena.estimators import create
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.landmark_extraction import landmark_sequence

ISAM2_END = np.array([-13.99, 0.53])  # iSAM2 with the file's ids and noise, its final position


def decisions(est) -> str:
    return f"matched/new/rejected {est.meta['matched']}/{est.meta['new']}/{est.meta['rejected']}"


def victoria_park(seq, params: dict) -> str:
    est = create("ekf_slam", **{"use_ids": False, **params}).run(seq)
    end = np.linalg.norm(est.poses[-1][:2] - ISAM2_END)
    return f"landmarks {len(est.landmark_ids)}, final position {end:.1f} m from iSAM2, {decisions(est)}"


def carpark(seq, params: dict) -> str:
    est = create("ekf_slam", **{"use_ids": False, **params}).run(seq)
    ref = reference_of(seq)
    trajectory, _ = ate(est, ref, ATEParams(align="se2", max_gap=0.25))
    m, _ = landmark_error(est, ref, MapParams(by="nearest", max_distance=2.0, max_gap=0.25))
    return (
        f"ATE {trajectory['rmse']:.3f} m, landmarks {len(est.landmark_ids)}, map RMS {m['rmse']:.3f} m, "
        f"matched {m['matched']}, spurious {m['spurious']}, {decisions(est)}"
    )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--data", default="vp,carpark")
    parser.add_argument("params", nargs="+")
    args = parser.parse_args()
    runs = {
        "vp": (victoria_park, lambda: datasets.load("victoria_park")),
        "carpark": (carpark, lambda: landmark_sequence(datasets.load("carpark"))),
    }
    for name in args.data.split(","):
        run, load = runs[name]
        seq = load()
        for spec in args.params:
            tic = time.process_time()
            print(f"{name} {spec}: {run(seq, json.loads(spec))}, cpu {time.process_time() - tic:.0f} s", flush=True)


if __name__ == "__main__":
    main()
