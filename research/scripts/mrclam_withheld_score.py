"""Score a finished ``slamarena run mrclam_withheld`` against a reference trajectory (Dataset 1 has no Vicon poses)
(research/notebook/2026-11-28-mrclam-withheld.md).

    python research/scripts/mrclam_withheld_score.py [results/mrclam_withheld] [--reference gtsam_batch]
        [--second ekf_localizer]

Per robot and method: ATE RMSE against the reference method's trajectory of the same run (SE(2)-aligned, the shipped
config's ``ate`` metric with the estimate as ground truth), its ratio to dead reckoning's, the map RMSE against the
surveyed landmarks aligned on them with landmarks 11 and 17 left out (Dataset 1's survey has their positions swapped
against the barcodes, ≈ 6 m), and the cell's status (a failed cell's error). The reference scores 0 against itself, so
every method is also scored against a second, independent reference (``--second``: the EKF localizer on the surveyed
map, which shares no code with the smoothers); on Dataset 6 the batch smoother is 0.115-0.202 m and the localizer
0.198-0.308 m from Vicon (research/results.md).
"""

import argparse
import json
from pathlib import Path

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.reference import MetricUnavailable, Reference
from slamarena.experiments.metrics.trajectory import ATEParams, ate

SWAPPED = [11, 17]
SURVEY = (
    Path(__file__).resolve().parents[2] / "../shared/datasets/utias_mrclam/MRCLAM_Dataset1/Landmark_Groundtruth.dat"
)


def survey(path: Path) -> Reference:
    table = np.loadtxt(path, comments="#")
    keep = ~np.isin(table[:, 0], SWAPPED)
    return Reference(None, None, table[keep, 0].astype(int), table[keep, 1:3], None)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("results", nargs="?", default="results/mrclam_withheld")
    ap.add_argument("--reference", default="gtsam_batch")
    ap.add_argument("--second", default="ekf_localizer")
    ap.add_argument("--survey", default=str(SURVEY))
    a = ap.parse_args()
    runs = Path(a.results) / "runs"
    surveyed = survey(Path(a.survey))
    for robot in sorted(p.name for p in runs.iterdir()):
        cells = {p.name: p / "0" for p in sorted((runs / robot).iterdir())}
        if not all((cells.get(name, runs) / "estimate.npz").exists() for name in (a.reference, a.second)):
            continue  # the reference has not run (yet)
        refs = {}
        for name in (a.reference, a.second):
            r = Estimate.load(cells[name] / "estimate.npz")
            refs[name] = Reference(r.t, r.poses, None, None, None)
        dr = dr_second = None
        for label, cell in cells.items():
            if not (cell / "metrics.json").exists():
                continue  # not run yet
            record = json.loads((cell / "metrics.json").read_text())
            if not (cell / "estimate.npz").exists():
                print(f"{robot} {label:15s} FAILED: {record.get('error', record.get('status'))}")
                continue
            est = Estimate.load(cell / "estimate.npz")
            score = ate(est, refs[a.reference], ATEParams(align="se2", max_gap=0.05))[0]
            second = ate(est, refs[a.second], ATEParams(align="se2", max_gap=0.05))[0]["rmse"]
            if label == "dead_reckoning":
                dr, dr_second = score["rmse"], second
            try:
                m = f"{landmark_error(est, surveyed, MapParams(by='id', align='se2'))[0]['rmse']:.3f}"
            except MetricUnavailable:
                m = "–"
            ratio = f"{dr / score['rmse']:.1f}×" if score["rmse"] > 1e-3 else "(ref)"
            ratio2 = f"{dr_second / second:.1f}×" if second > 1e-3 else "(ref)"
            print(
                f"{robot} {label:15s} ATE vs {a.reference} {score['rmse']:.3f} (max {score['max']:.2f}) DR/ATE {ratio:>6s}"
                f" | vs {a.second} {second:.3f} DR/ATE {ratio2:>6s} | map (no 11, 17) {m} | {record.get('status', 'ok')}",
                flush=True,
            )


if __name__ == "__main__":
    main()
