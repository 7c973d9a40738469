"""Error over time: ATE position and heading error of every method, per dataset.

Each method's line is the mean over its seeds at the first seed's stamps (the other seeds are
linearly interpolated onto them); the band spans the 10–90 % range across seeds.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.series import Series

from .runs import FigureSkipped, by, load_runs
from .style import WIDTH, apply, method_style, plt, save

__all__ = ["plot"]


def _across_seeds(runs, key):
    ref = runs[0].series
    t = ref[Series.ATE_T]
    rows = [np.interp(t, r.series[Series.ATE_T], r.series[key]) for r in runs if Series.ATE_T in r.series]
    rows = np.array(rows)
    return t, rows.mean(axis=0), np.percentile(rows, 10, axis=0), np.percentile(rows, 90, axis=0)


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs = [r for r in load_runs(results_dir) if Series.ATE_T in r.series]
    if not runs:
        raise FigureSkipped("no ATE series (is the ate metric enabled?)")
    apply()
    methods = sorted({r.estimator for r in runs})
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        fig, (ax_p, ax_h) = plt.subplots(2, 1, figsize=(WIDTH, WIDTH * 0.7), sharex=True)
        for (estimator,), seeds in by(group, "estimator").items():
            style = method_style(estimator, methods)
            for ax, key, scale in ((ax_p, Series.ATE_POSITION_ERROR, 1.0), (ax_h, Series.ATE_HEADING_ERROR, 180 / np.pi)):
                t, mean, lo, hi = _across_seeds(seeds, key)
                ax.plot(t, mean * scale, **style)
                if len(seeds) > 1:
                    ax.fill_between(t, lo * scale, hi * scale, color=style["color"], alpha=0.2, linewidth=0)
        n = len({r.seed for r in group})
        ax_p.set_ylabel("position error [m]")
        ax_h.set_ylabel("heading error [deg]")
        ax_h.set_xlabel("time [s]")
        ax_p.set_title(f"{dataset}: error after the ATE alignment (mean over {n} seed{'s' * (n > 1)}, band 10–90 %)")
        ax_p.legend(loc="upper left")
        written += save(fig, out_dir, f"errors_{dataset}")
    return written
