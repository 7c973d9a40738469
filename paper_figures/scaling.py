"""Log-log scaling of cost with problem size, with fitted slopes.

A sweep is a dataset name that appears in the experiment with several parameter sets that
differ in exactly one numeric parameter (e.g. ``sim:landmarks`` with ``n_landmarks`` 50, 100,
200, 400). For each method the median step time and the wall time (mean over seeds) are
plotted against that parameter on log-log axes, with the least-squares line
``log y = a + b log x``; the slope ``b`` is the empirical exponent (EKF-SLAM's update is
O(n²) per observation: b ≈ 2 at large n).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from matplotlib.ticker import NullFormatter

from .runs import FigureSkipped, by, load_runs
from .style import WIDTH, apply, method_style, plt, save

__all__ = ["plot", "find_sweeps", "fit_slope"]

COSTS = (("cost/step_median", "median step time [s]"), ("cost/wall", "wall time [s]"))


def fit_slope(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(slope b, intercept a) of the least-squares line log y = a + b log x."""
    b, a = np.polyfit(np.log(x), np.log(y), 1)
    return float(b), float(a)


def find_sweeps(runs) -> dict[tuple[str, str], dict[str, float]]:
    """(dataset name, swept parameter) → {dataset label: parameter value}.

    Entries of one dataset name whose parameters agree except for one numeric, positive
    parameter form a sweep of it (at least two values).
    """
    entries: dict[str, dict[str, dict]] = {}
    for run in runs:
        entries.setdefault(run.info["dataset"]["name"], {})[run.dataset] = run.info["dataset"]["params"]
    sweeps = {}
    for name, labelled in entries.items():
        for key in sorted(set().union(*(p.keys() for p in labelled.values()))):
            groups: dict[str, dict[str, float]] = {}
            for label, p in labelled.items():
                value = p.get(key)
                if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0:
                    rest = json.dumps({k: v for k, v in p.items() if k != key}, sort_keys=True)
                    groups.setdefault(rest, {})[label] = float(value)
            for group in groups.values():
                if len(set(group.values())) >= 2 and len(group) > len(sweeps.get((name, key), {})):
                    sweeps[(name, key)] = group
    return sweeps


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs = load_runs(results_dir)
    sweeps = find_sweeps(runs)
    if not sweeps:
        raise FigureSkipped("no parameter sweep (a dataset listed with one numeric parameter varied)")
    apply()
    methods = sorted({r.estimator for r in runs})
    written = []
    for (name, param), values in sweeps.items():
        fig, axes = plt.subplots(1, len(COSTS), figsize=(WIDTH, WIDTH * 0.45), squeeze=False, layout="constrained")
        swept = [r for r in runs if r.dataset in values]
        for ax, (key, label) in zip(axes[0], COSTS):
            metric, output = key.split("/")
            for (estimator,), group in by(swept, "estimator").items():
                points = {}
                for r in group:
                    v = r.info["metrics"].get(metric, {}).get(output)
                    if v is not None and v > 0:
                        points.setdefault(values[r.dataset], []).append(v)
                if len(points) < 2:
                    continue
                x = np.array(sorted(points))
                y = np.array([np.mean(points[k]) for k in x])
                b, a = fit_slope(x, y)
                style = method_style(estimator, methods)
                ax.loglog(x, y, marker="o", color=style["color"], linestyle="none")
                ax.loglog(x, np.exp(a) * x**b, color=style["color"], linestyle=style["linestyle"], label=f"{estimator}: slope {b:.2f}")
            ticks = sorted(set(values.values()))
            ax.set_xticks(ticks, [f"{v:g}" for v in ticks])
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel(param)
            ax.set_ylabel(label)
            if ax.lines:
                ax.legend(loc="upper left")
        fig.suptitle(f"{name}: cost vs {param} (log-log, least-squares slopes)")
        written += save(fig, out_dir, f"scaling_{name.replace(':', '_')}_{param}")
    return written
