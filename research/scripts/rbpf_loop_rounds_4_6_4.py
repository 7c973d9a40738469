"""notebook/2026-11-23-rbpf-loop-rounds-4-6.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_loop_rounds_4_6_4.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import glob
import json
import statistics as st


def main() -> None:
    rows = {}
    for f in sorted(glob.glob("results/loop_closure/runs/long_loop/*/*/metrics.json")):
        m = json.load(open(f))
        rows.setdefault(m["estimator"]["label"], {})[int(f.split("/")[-2])] = m["metrics"]["loop"]["trans_mean"]
    g = rows["grid_slam"]
    for e in ("rbpf", "laser_slam"):
        r = rows[e]
        print(
            e,
            "below grid_slam on",
            sum(r[s] < g[s] for s in g),
            "of",
            len(g),
            "median %.3f" % st.median(r.values()),
            "closed (<= 0.35 m)",
            sum(v <= 0.35 for v in r.values()),
        )


if __name__ == "__main__":
    main()
