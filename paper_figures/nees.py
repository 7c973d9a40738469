"""NEES over time with its χ² band, one panel per method that has a pose NEES, per dataset.

The pose NEES of the N seeds is averaged at the stamps they share; ``N ε̄`` is χ²(3N) for a
consistent filter, so the two-sided 95 % band is ``[χ²_{3N}(0.025), χ²_{3N}(0.975)] / N``
(:func:`slamarena.experiments.metrics.consistency.monte_carlo`). The y axis is logarithmic: an
inconsistent filter leaves the band by orders of magnitude; its limits are robust (the 0.5–99.5 %
quantiles and the band), so a prior's near-zero NEES at t = 0 does not stretch it. A method without a
NEES (no covariance, the metric skipped, or seeds that share no stamp) has no panel.
"""

from __future__ import annotations

from pathlib import Path

from slamarena.experiments.metrics.series import Series

from .runs import FigureSkipped, by
from .style import figure_runs, log_axis, panel_grid, panels_used, robust_limits, save

__all__ = ["plot"]


def plot(results_dir: str | Path, out_dir: str | Path, probability: float = 0.95) -> list[Path]:
    from slamarena.experiments.metrics.consistency import monte_carlo
    from slamarena.experiments.metrics.reference import MetricUnavailable

    runs, styles = figure_runs(
        results_dir,
        lambda r: Series.NEES in r.series,
        "no NEES series (no method with covariances, or the nees metric is off)",
    )
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        panels = {}
        for (estimator,), seeds in by(group, "estimator").items():
            try:
                panels[estimator] = monte_carlo(
                    [(r.series[Series.NEES_T], r.series[Series.NEES]) for r in seeds], 3, probability
                )
            except MetricUnavailable:
                continue
        if not panels:
            continue
        fig, axes = panel_grid(len(panels), 1.25, sharex=True)
        for ax, (estimator, mc) in zip(axes.flat, panels.items()):
            style = styles(estimator)
            ax.fill_between(
                mc["t"],
                mc["lo"],
                mc["hi"],
                color="0.85",
                linewidth=0,
                label=f"χ² {probability:.0%} band of the mean of N runs",
            )
            ax.axhline(3.0, color="black", linewidth=0.6, linestyle=":", label="E[NEES] = 3")
            ax.plot(mc["t"], mc["mean"], color=style["color"], linestyle=style["linestyle"], label=estimator)
            log_axis(ax, "y", robust_limits([mc["mean"]], log=True, include=[mc["lo"].min(), mc["hi"].max()]))
            ax.set_title(f"{estimator}: N = {mc['runs']}, {mc['in_band']:.0%} of stamps in band")
            ax.set_ylabel("NEES")
        panels_used(axes, len(panels), "time [s]")
        caption = (
            f"{dataset}: pose NEES (3 degrees of freedom) averaged over the N seeds at their shared stamps, one panel "
            f"per method that has a pose covariance, with the two-sided {probability:.0%} band of a consistent filter, "
            f"[χ²₃N(0.025), χ²₃N(0.975)] / N; log scale, y range spanning the band and 0.5–99.5 % of the values."
        )
        written += save(fig, out_dir, f"nees_{dataset}", caption)
    if not written:
        raise FigureSkipped("no method's seeds share a NEES stamp")
    return written
