"""Log-log scaling of cost with problem size, with fitted exponents and crossovers.

A sweep is a dataset name that appears in the experiment with several parameter sets that
differ in exactly one numeric parameter (e.g. ``sim:landmarks`` with ``n_landmarks`` 50, 100,
200, 400). For each method the median step time, the total step time (on the clock the method's
``step_clock`` names: CPU time in the cost study) and the wall time (mean over seeds) are
plotted against that parameter on log-log axes, with the least-squares line
``log y = a + b log x``; the slope ``b`` is the empirical exponent (EKF-SLAM's update is
O(n²) per observation: b ≈ 2 at large n).

Crossovers: two methods' fitted lines meet where ``a₁ + b₁ log x = a₂ + b₂ log x``, at
``x* = exp((a₂ − a₁) / (b₁ − b₂))``; beyond it the method with the larger exponent is the slower. A crossover
inside the swept range is marked on the axes; one outside it (an extrapolation of the fits) is only named in the
caption, and only within a factor ``EXTRAPOLATE`` of the range.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.ticker import NullFormatter

from .runs import FigureSkipped, by, load_runs
from .style import PAGE, MethodStyles, figure, save

__all__ = ["plot", "find_sweeps", "fit_slope", "crossovers", "spread", "EXTRAPOLATE"]

COSTS = (
    ("cost/step_median", "median step time [s]"),
    ("cost/step_total", "total step time [s]"),
    ("cost/wall", "wall time [s]"),
)
EXTRAPOLATE = 10.0


def fit_slope(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(slope b, intercept a) of the least-squares line log y = a + b log x."""
    b, a = np.polyfit(np.log(x), np.log(y), 1)
    return float(b), float(a)


def spread(levels: np.ndarray, gap: float) -> np.ndarray:
    """Label positions (same order as ``levels``) at least ``gap`` apart and as close to ``levels`` as the gap allows: each
    run of labels closer than the gap is centred on its mean and spaced by the gap (the exponents written at the lines'
    ends, in log10 units, so that two lines ending close together keep legible labels)."""
    order = np.argsort(levels, kind="stable")
    groups = [[float(levels[i])] for i in order]
    merged = True
    while merged:  # merge neighbouring groups whose spaced extents overlap
        merged = False
        out, centres = [], []
        for g in groups:
            centre = float(np.mean(g))
            if out and centre - (len(g) - 1) * gap / 2 < centres[-1] + (len(out[-1]) - 1) * gap / 2 + gap:
                out[-1] += g
                centres[-1] = float(np.mean(out[-1]))
                merged = True
            else:
                out.append(list(g))
                centres.append(centre)
        groups = out
    positions = np.concatenate([np.mean(g) + (np.arange(len(g)) - (len(g) - 1) / 2) * gap for g in groups])
    result = np.empty_like(positions)
    result[order] = positions
    return result


def crossovers(fits: dict[str, tuple[float, float]]) -> list[tuple[str, str, float]]:
    """Every pair of fitted lines (name → (slope b, intercept a)) that meet at a positive x: (name₁, name₂, x*),
    name₁ the method with the larger exponent (the slower one beyond x*)."""
    out = []
    names = list(fits)
    for i, m in enumerate(names):
        for n in names[i + 1 :]:
            (b1, a1), (b2, a2) = fits[m], fits[n]
            if np.isclose(b1, b2):
                continue
            out.append(
                (m, n, float(np.exp((a2 - a1) / (b1 - b2))))
                if b1 > b2
                else (n, m, float(np.exp((a1 - a2) / (b2 - b1))))
            )
    return out


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
    styles = MethodStyles.of(results_dir, runs)
    written = []
    for (name, param), values in sweeps.items():
        fig, axes = figure(PAGE, 2.6, ncols=len(COSTS))
        swept = [r for r in runs if r.dataset in values]
        lo, hi = min(values.values()), max(values.values())
        notes = []
        for ax, (key, label) in zip(axes[0], COSTS):
            metric, output = key.split("/")
            fits = {}
            labels = []  # (x, log10 y, text, colour) of each fitted line's end
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
                fits[estimator] = (b, a)
                style = styles(estimator)
                ax.loglog(x, y, marker="o", markersize=3, color=style["color"], linestyle="none")
                ax.loglog(x, np.exp(a) * x**b, color=style["color"], linestyle=style["linestyle"], label=estimator)
                labels.append((x[-1], np.log10(np.exp(a) * x[-1] ** b), f"{b:.2f}", style["color"]))
            if labels:
                low, high = np.log10(ax.get_ylim())
                at = spread(
                    np.array([lv for _, lv, _, _ in labels]), 0.07 * (high - low)
                )  # ≈ one 6 pt line of the axis
                for (xe, _, text, colour), lv in zip(labels, at):
                    ax.annotate(
                        text,
                        (xe, 10**lv),
                        xytext=(3, 0),
                        textcoords="offset points",
                        fontsize=6,
                        color=colour,
                        va="center",
                    )
            for slower, faster, x_star in crossovers(fits):
                if lo <= x_star <= hi:
                    b, a = fits[slower]
                    ax.plot(
                        [x_star],
                        [np.exp(a) * x_star**b],
                        marker="D",
                        markersize=4,
                        markerfacecolor="none",
                        color="black",
                        linestyle="none",
                        label="crossover of two fits",
                    )
                    notes.append(f"{label.split(' [')[0]}: {slower} passes {faster} at {param} ≈ {x_star:.3g}")
                elif lo / EXTRAPOLATE <= x_star <= hi * EXTRAPOLATE:
                    notes.append(
                        f"{label.split(' [')[0]}: the fits of {slower} and {faster} would cross at {param} ≈ {x_star:.3g}, "
                        "outside the sweep (extrapolated)"
                    )
            ticks = sorted(set(values.values()))
            ax.set_xticks(
                ticks, [f"{v:g}" for v in ticks], rotation=45 if len(ticks) > 5 else 0
            )  # a third of a page: 7 labels crowd
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel(param)
            ax.set_ylabel(label)
        caption = (
            f"{name}: cost against {param} on log-log axes, mean over seeds (points) and the least-squares line "
            f"log y = a + b log {param} per method, its exponent b written at the line's end. Crossovers (◇) are where two "
            f"fitted lines meet inside the sweep. "
            + ("; ".join(notes) + "." if notes else "No two fits cross within the sweep.")
        )
        written += save(fig, out_dir, f"scaling_{name.replace(':', '_')}_{param}", caption)
    return written
