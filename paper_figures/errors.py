"""Error over time: ATE position and heading error of every method, per dataset.

Each method's line is the mean over its seeds at the first seed's stamps (the other seeds are
linearly interpolated onto them); the band spans the 10–90 % range across seeds. The y axes are
logarithmic (errors of the methods of one run differ by orders of magnitude: dead reckoning's metres,
a smoother's centimetres) with robust limits (:func:`slamarena.paper_figures.style.robust_limits`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.series import Series

from .runs import by
from .style import COLUMN, figure, figure_runs, log_axis, robust_limits, save

__all__ = ["plot"]


def _across_seeds(runs, key):
    ref = runs[0].series
    t = ref[Series.ATE_T]
    rows = np.array([np.interp(t, r.series[Series.ATE_T], r.series[key]) for r in runs])
    return t, rows.mean(axis=0), np.percentile(rows, 10, axis=0), np.percentile(rows, 90, axis=0)


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs, styles = figure_runs(
        results_dir,
        lambda r: r.series.get(Series.ATE_T, np.zeros(0)).size > 0,
        "no ATE series (is the ate metric enabled?)",
    )
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        methods = by(group, "estimator")
        fig, axes = figure(COLUMN, 2.6 + 0.15 * (len(methods) + 1) / 2, nrows=2, sharex=True)
        ax_p, ax_h = axes[:, 0]
        drawn = {ax_p: [], ax_h: []}
        for (estimator,), seeds in methods.items():
            style = styles(estimator)
            for ax, key, scale in (
                (ax_p, Series.ATE_POSITION_ERROR, 1.0),
                (ax_h, Series.ATE_HEADING_ERROR, 180 / np.pi),
            ):
                t, mean, lo, hi = _across_seeds(seeds, key)
                ax.plot(t, mean * scale, **style)
                drawn[ax].append(mean * scale)
                if len(seeds) > 1:
                    ax.fill_between(t, lo * scale, hi * scale, color=style["color"], alpha=0.2, linewidth=0)
        for ax, label in ((ax_p, "position error [m]"), (ax_h, "heading error [deg]")):
            log_axis(ax, "y", robust_limits(drawn[ax], log=True))
            ax.set_ylabel(label)
        ax_h.set_xlabel("time [s]")
        n = len({r.seed for r in group})
        caption = (
            f"{dataset}: ATE position (top) and heading (bottom) error over time after each cell's ATE alignment, "
            f"mean over {n} seed{'s' * (n > 1)}"
            + (" with the 10–90 % range across seeds shaded" if n > 1 else "")
            + "; log scale, y range spanning 0.5–99.5 % of the drawn values."
        )
        written += save(fig, out_dir, f"errors_{dataset}", caption)
    return written
