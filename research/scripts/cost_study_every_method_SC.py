"""notebook/2026-11-23-cost-study-every-method.md, script SC (SC)

Run from the repository root: ``python research/scripts/cost_study_every_method_SC.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import pandas as pd

from slamarena.paper_figures.scaling import fit_slope


def main() -> None:
    d = pd.read_csv("results/scaling/summary.csv")
    d["n"] = d.dataset.str[2:].astype(int)
    order = ["dead_reckoning", "ekf_slam", "ekf_slam_batch", "gtsam_isam2", "fastslam"]

    def fmt(r):
        return (
            f"{1e3 * r['cost.step_median']:.2f} / {1e3 * r['cost.step_p95']:.2f} / {r['cost.step_total']:.3g} s / "
            f"{r['cost.peak_rss_mb']:.0f} MiB / {r['ate.rmse']:.3g} m"
        )

    for n, g in d.groupby("n"):
        g = g.set_index("estimator")
        print(f"| {n} | " + " | ".join(fmt(g.loc[e]) for e in order) + " |")
    for e in order:
        g = d[d.estimator == e].sort_values("n")
        hi = g[g.n >= 800]
        f = lambda s, k: fit_slope(s.n.values, s[k].values)[0]
        print(
            e,
            f"{f(g, 'cost.step_median'):.2f} | {f(hi, 'cost.step_median'):.2f} | {f(hi, 'cost.step_p95'):.2f} | {f(hi, 'cost.step_total'):.2f} | {f(hi, 'cost.peak_rss_mb'):.2f}",
        )


if __name__ == "__main__":
    main()
