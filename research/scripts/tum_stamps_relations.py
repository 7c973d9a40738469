"""notebook/2026-11-28-tum-stamps.md: Intel's relations scored from a trajectory.tum as a relations tool would,
knowing only the file's stamps.

Run from the repository root after ``slamarena map carmen:intel --method laser_slam --out OUT``:
``python research/scripts/tum_stamps_relations.py OUT``. Scores OUT/trajectory.tum (the log's own stamps) and the
same estimate at the reader's adjusted stamps (OUT/estimate.npz ``t``, what trajectory.tum carried before), each
with the relations matched by exact stamp and by the metric's default (nearest within 0.05 s); evo reads both.
"""

import sys
import tempfile
from pathlib import Path

from evo.tools import file_interface

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.formats import relations, tum
from slamarena.experiments.metrics.relations import RelationsParams, relation_error

RELATIONS = "../shared/datasets/radish_laser_logs/relations/intel.relations"


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "results/maps")
    rel = relations.read(RELATIONS)
    estimate = Estimate.load(out / "estimate.npz")
    with tempfile.TemporaryDirectory() as tmp:
        adjusted = Path(tmp) / "adjusted.tum"
        tum.write(adjusted, estimate.t, estimate.poses)  # the old convention: the reader's times
        for name, path in (("adjusted stamps (before)", adjusted), ("log's own stamps (now)", out / "trajectory.tum")):
            evo = file_interface.read_tum_trajectory_file(str(path))
            traj = tum.read_trajectory(path)
            for match, tol in (("exact", 0.0), ("nearest 0.05 s", 0.05)):
                s, _ = relation_error(
                    Estimate("tum", traj.t, traj.poses), rel.t1, rel.t2, rel.se2, RelationsParams(tolerance=tol)
                )
                print(
                    f"{name:26s} evo ok={evo.check()[0]!s:5s} {match:15s} used {s['used']:4d} dropped "
                    f"{s['dropped']:4d}  trans {s['trans_mean']:.4f} ± {s['trans_std']:.4f} m  "
                    f"rot {s['rot_mean']:.4f} rad"
                )


if __name__ == "__main__":
    main()
