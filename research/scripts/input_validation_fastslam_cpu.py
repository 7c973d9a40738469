"""notebook/2026-11-28-input-validation.md: the CPU time of a FastSLAM run, to compare the row checks' cost.

Run from the repository root: ``python research/scripts/input_validation_fastslam_cpu.py 100 100 3`` (particles,
landmarks of sim:landmarks with seed 1, timed runs), once with each version of ``estimators/fastslam/filter.py`` in
the worktree. Prints the minimum process CPU time of the timed runs (after one compiling run) and the number of
range-bearing rows. A notebook figure: measured at the commits the page names.
"""

import sys
import time

from slamarena import datasets
from slamarena.estimators.fastslam import FastSLAM


def main() -> None:
    particles, n_landmarks, repeats = (int(a) for a in sys.argv[1:4])
    seq = datasets.load("sim:landmarks", n_landmarks=n_landmarks, seed=1)
    FastSLAM(particles=particles, seed=0).run(seq)  # compile
    ts = []
    for _ in range(repeats):
        t = time.process_time()
        FastSLAM(particles=particles, seed=0).run(seq)
        ts.append(time.process_time() - t)
    print("min CPU s", min(ts), "rows", len(seq.range_bearing))


#: ``--quick``: 5 particles, 20 landmarks, one timed run (the page: 100 particles, 100 landmarks, 3 runs).
QUICK = ["5", "20", "1"]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        sys.argv[1:] = QUICK
    main()
