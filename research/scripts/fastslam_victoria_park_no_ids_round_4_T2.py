"""notebook/2026-11-23-fastslam-victoria-park-no-ids-round-4.md, script T2 (T2: every update of a stretch (M, seed, from, to), from T's files)

Run from the repository root: ``python research/scripts/fastslam_victoria_park_no_ids_round_4_T2.py 50 0 2250 2450``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import pickle
import sys

import numpy as np

from slamarena import datasets
from slamarena.datasets.estimate import Estimate


def main() -> None:
    M, seed, a, b = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    rec = pickle.load(open(f"T_{M}_{seed}.pkl", "rb"))
    E = np.load(f"T_{M}_{seed}.npz")
    ekf = Estimate.load("results/victoria_park/runs/victoria_park/ekf_slam_nn_managed/0/estimate.npz")
    dg = ekf.diagnostics
    rb = datasets.load("victoria_park").range_bearing
    for r in rec:
        if not (a <= r["t"] <= b):
            continue
        bst = r["best"]
        s = []
        for j, row in enumerate(r["rows"]):
            d = "N" + ("d" if r["dup"][bst, j] else "") if r["new"][bst, j] else ("m" if r["right"][bst, j] else "W")
            e = "mN?R"[dg["assoc_decision"][row]] if dg["assoc_decision"][row] < 3 else "?"
            s.append(
                f"{rb.landmark_id[row]}:{rb.range[row]:.0f}m FS {d} (near {r['near'][bst, j]:.0f} true {r['tru'][bst, j]:.0f}, min true over particles {r['tru'][:, j].min():.0f}) EKF {'mNR'[dg['assoc_decision'][row]]} d² {dg['assoc_d2'][row]:.1f}"
            )
        print(
            f"t {r['t']:.0f} err vs EKF {np.interp(r['t'], E['t'], E['e_ekf']):.1f} vs iSAM2 {np.interp(r['t'], E['t'], E['e_isam']):.1f} | "
            + "; ".join(s)
        )


if __name__ == "__main__":
    main()
