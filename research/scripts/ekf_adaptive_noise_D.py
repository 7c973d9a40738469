"""EKF-SLAM's defaults without ids and with self_identify=True on Victoria Park: landmarks, final position from
iSAM2's with ids, the scales chosen and every walk's log-likelihood (research/notebook/2026-11-28-ekf-adaptive-noise.md,
script D).

    python research/scripts/ekf_adaptive_noise_D.py ['{EKF-SLAM parameters}']
"""

import json
import sys
import time

import numpy as np

from slamarena import datasets
from slamarena.estimators import create


def main() -> None:
    params = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    seq = datasets.load("victoria_park")
    tic = time.process_time()
    est = create("ekf_slam", **{"use_ids": False, "self_identify": True, **params}).run(seq)
    ni = est.meta.get("noise_identification")
    print(
        params,
        "landmarks",
        len(est.landmark_ids),
        "end %.1f m" % np.linalg.norm(est.poses[-1][:2] - [-13.99, 0.53]),
        "m/n/r",
        est.meta["matched"],
        est.meta["new"],
        est.meta["rejected"],
        "scales",
        est.meta["noise_scale"],
        "cpu %.0f s" % (time.process_time() - tic),
    )
    print(json.dumps({k: v for k, v in ni.items() if k != "runs"}), [(i, j, round(l)) for i, j, l in ni["runs"]])


if __name__ == "__main__":
    main()
