"""notebook/2026-11-28-tum-stamps.md: laser graph SLAM's time per scan on Intel, split by what the scan ran.

Run from the repository root after ``slamarena map carmen:intel --method laser_slam --out OUT``:
``python research/scripts/tum_stamps_step_times.py OUT``. Prints the median, 95th percentile, three largest and sum
of the per-scan times beside the stage timers' total, then the medians of scans that are not graph nodes, node scans
without a loop search, and node scans with one.
"""

import sys
from pathlib import Path

import numpy as np

from slamarena.datasets.estimate import Estimate


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/stamps_map_intel")
    e = Estimate.load(out / "estimate.npz")
    st, d = e.step_time, e.diagnostics
    print(np.median(st), np.percentile(st, 95), np.sort(st)[-3:], st.sum(), sum(e.meta["seconds"].values()))
    node = np.zeros(len(st), bool)
    node[d["node_scan"]] = True
    search = np.zeros(len(st), bool)
    search[d["node_scan"][:: e.meta["params"]["loop"]["search_every"]]] = True
    print(np.median(st[~node]), np.median(st[node & ~search]), np.median(st[search]))


if __name__ == "__main__":
    main()
