"""NEES over time with its χ² band, per dataset and method.

The pose NEES of the N seeds is averaged at the stamps they share; ``N ε̄`` is χ²(3N) for a
consistent filter, so the two-sided 95 % band is ``[χ²_{3N}(0.025), χ²_{3N}(0.975)] / N``
(:func:`slamarena.experiments.metrics.consistency.monte_carlo`). The y axis is logarithmic: an
inconsistent filter leaves the band by orders of magnitude.
"""
from __future__ import annotations

from pathlib import Path

from slamarena.experiments.metrics.series import Series

from .runs import FigureSkipped, by, load_runs
from .style import WIDTH, apply, method_style, plt, save

__all__ = ["plot"]


def plot(results_dir: str | Path, out_dir: str | Path, probability: float = 0.95) -> list[Path]:
    from slamarena.experiments.metrics.consistency import monte_carlo

    runs = [r for r in load_runs(results_dir) if Series.NEES in r.series]
    if not runs:
        raise FigureSkipped("no NEES series (no method with covariances, or the nees metric is off)")
    apply()
    methods = sorted({r.estimator for r in runs})
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        per_method = by(group, "estimator")
        fig, axes = plt.subplots(len(per_method), 1, figsize=(WIDTH, 2.0 * len(per_method) + 0.6), sharex=True, squeeze=False)
        for ax, ((estimator,), seeds) in zip(axes[:, 0], per_method.items()):
            mc = monte_carlo([(r.series[Series.NEES_T], r.series[Series.NEES]) for r in seeds], 3, probability)
            style = method_style(estimator, methods)
            ax.plot(mc["t"], mc["mean"], color=style["color"], label=f"{estimator}: mean NEES over {mc['runs']} run{'s' * (mc['runs'] > 1)}")
            ax.fill_between(mc["t"], mc["lo"], mc["hi"], color="0.6", alpha=0.3, linewidth=0, label=f"χ² {probability:.0%} band ({mc['in_band']:.0%} of steps inside)")
            ax.axhline(3.0, color="black", linewidth=0.6, linestyle=":")
            ax.set_yscale("log")
            ax.set_ylabel("NEES")
            ax.legend(loc="upper left")
        axes[-1, 0].set_xlabel("time [s]")
        axes[0, 0].set_title(f"{dataset}: pose NEES (dimension 3)")
        written += save(fig, out_dir, f"nees_{dataset}")
    return written
