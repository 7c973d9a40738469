"""EKF-SLAM without ids on Victoria Park with the parameters given as JSON, one run each: landmarks made, the final
position's distance to iSAM2's with ids (−13.99, 0.53; research/notebook/2026-11-23-ekf-slam-victoria-park.md), the
decisions and the CPU time (research/notebook/2026-11-28-landmark-real-data.md).

    python research/scripts/landmark_real_data_vp_defaults.py '{"use_ids": false}' '{"use_ids": false, "window": 20}'
"""

import json
import sys
import time

import numpy as np

from slamarena import datasets
from slamarena.estimators import create

ISAM2_END = np.array([-13.99, 0.53])  # iSAM2 with the file's ids and noise, its final position


def main():
    seq = datasets.load("victoria_park")
    for spec in sys.argv[1:]:
        tic = time.process_time()
        est = create("ekf_slam", **json.loads(spec)).run(seq)
        print(
            spec,
            f"landmarks {len(est.landmark_ids)}, final position {np.linalg.norm(est.poses[-1][:2] - ISAM2_END):.1f} m from iSAM2, "
            f"matched/new/rejected {est.meta['matched']}/{est.meta['new']}/{est.meta['rejected']}, "
            f"cpu {time.process_time() - tic:.0f} s",
        )


if __name__ == "__main__":
    main()
