"""Relation error (Kümmerle et al. 2009) per log: the distribution on each log, and the means across logs.

``relations_<dataset>``: for each method, the empirical distribution of the translational and rotational errors
of the relations it matched (``series.npz`` ``relations/trans_error``, ``relations/rot_error``; every seed's
relations pooled): the fraction of relations whose error is at most x, on a log x axis. A curve to the left is
the better method; the gap between curves at a given fraction is a ratio of errors.

``relations``: every log on one axis, each method's mean ± std of the errors over its relations (the numbers of
the ``relations`` table), and beside them the published rows of the config (``published:``, marked
"(published)") where they give ``relations.trans_mean`` / ``relations.rot_mean``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.series import Series

from .runs import by, load_manifest
from .style import COLUMN, PAGE, figure, figure_runs, log_axis, robust_limits, save

__all__ = ["plot", "ecdf"]

PANELS = (
    (Series.RELATIONS_TRANS_ERROR, "trans", 1.0, "translational error [m]"),
    (Series.RELATIONS_ROT_ERROR, "rot", 180 / np.pi, "rotational error [deg]"),
)


def ecdf(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sorted values, fraction of values ≤ each): the empirical distribution function at its steps."""
    x = np.sort(np.asarray(values, dtype=float))
    return x, np.arange(1, x.size + 1) / x.size


def _pooled(seeds, key) -> np.ndarray:
    return np.concatenate([r.series[key] for r in seeds])


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs, styles = figure_runs(
        results_dir,
        lambda r: r.series.get(Series.RELATIONS_TRANS_ERROR, np.zeros(0)).size > 0,
        "no relation errors (the relations metric is off, or no dataset has a relations file)",
    )
    written = []
    logs = by(runs, "dataset")
    for (dataset,), group in logs.items():
        fig, axes = figure(COLUMN, 2.0 + 0.15 * (len(by(group, "estimator")) + 1) / 2, ncols=2, sharey=True)
        counts = []
        for (estimator,), seeds in by(group, "estimator").items():
            for ax, (key, _, scale, _) in zip(axes[0], PANELS):
                x, F = ecdf(_pooled(seeds, key) * scale)
                ax.step(x, F, where="post", **styles(estimator))
            counts.append(f"{estimator} {_pooled(seeds, Series.RELATIONS_TRANS_ERROR).size}")
        for ax, (key, _, scale, label) in zip(axes[0], PANELS):
            log_axis(ax, "x", robust_limits([_pooled(group, key) * scale], log=True))
            ax.set_xlabel(label)
        axes[0, 0].set_ylabel("fraction of relations")
        caption = (
            f"{dataset}: distribution of the relation errors ε_ij = δ*_ij⁻¹ δ_ij (Kümmerle et al. 2009) of each method, "
            f"the fraction of relations whose translational (left) or rotational (right) error is at most x, log x axis; "
            f"relations matched per method (seeds pooled): {', '.join(counts)}."
        )
        written += save(fig, out_dir, f"relations_{dataset}", caption)

    published = [
        row
        for row in load_manifest(results_dir).get("config", {}).get("published", [])
        if any(
            f"relations.{stat}_mean" in values for values in row.get("values", {}).values() for _, stat, _, _ in PANELS
        )
    ]
    labels = [d for (d,) in logs]
    present = {r.estimator for r in runs}
    methods = [m for m in styles.labels() if m in present]
    columns = len(methods) + len(published)
    width = 0.8 / columns
    fig, axes = figure(PAGE, 2.6, ncols=2)
    for ax, (key, stat, scale, label) in zip(axes[0], PANELS):
        values = []
        for k, estimator in enumerate(methods):
            style = styles(estimator)
            for i, dataset in enumerate(labels):
                seeds = [r for r in logs[(dataset,)] if r.estimator == estimator]
                if seeds:
                    e = _pooled(seeds, key) * scale
                    values.append(e)
                    ax.errorbar(
                        i - 0.4 + (k + 0.5) * width,
                        e.mean(),
                        yerr=[[min(e.std(), 0.9 * e.mean())], [e.std()]],
                        marker="o",
                        markersize=3,
                        color=style["color"],
                        linestyle="none",
                        elinewidth=0.8,
                        capsize=1.5,
                        label=estimator,
                    )
        for k, row in enumerate(published, start=len(methods)):
            for i, dataset in enumerate(labels):
                v = row["values"].get(dataset, {})
                if f"relations.{stat}_mean" in v:
                    m, s = v[f"relations.{stat}_mean"] * scale, v.get(f"relations.{stat}_std", 0.0) * scale
                    values.append([m])
                    ax.errorbar(
                        i - 0.4 + (k + 0.5) * width,
                        m,
                        yerr=[[min(s, 0.9 * m)], [s]],
                        marker="s",
                        markersize=3,
                        markerfacecolor="white",
                        color="0.3",
                        linestyle="none",
                        elinewidth=0.8,
                        capsize=1.5,
                        label=f"{row['label']} (published)",
                    )
        log_axis(ax, "y", robust_limits(values, log=True))
        ax.set_xticks(range(len(labels)), labels, rotation=20 if len(labels) > 3 else 0)
        ax.set_xlim(-0.5, len(labels) - 0.5)
        ax.set_ylabel(label)
        ax.grid(False, axis="x")
    cited = "".join(f" {row['label']} (published): {row['citation']}." for row in published)
    caption = (
        "Relation error per log: each method's mean ± std over its relations (seeds pooled), translational (left) and "
        "rotational (right), log scale (a lower bar is cut at 10 % of the mean)." + cited
    )
    written += save(fig, out_dir, "relations", caption)
    return written
