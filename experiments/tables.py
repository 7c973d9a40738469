"""Comparison tables in Markdown, CSV and LaTeX from one pandas frame.

Input: the summary frame (one row per cell: ``dataset``, ``estimator``, ``seed``, ``status``
and ``<metric>.<output>`` columns). Each table groups the successful cells by (dataset,
method) and reports ``mean ± std`` over the seeds (``std`` with ``ddof=1``; a single run shows
the mean alone) and ``n``, the number of seeds. In every column the best mean within each
dataset is marked — bold in Markdown and LaTeX, a trailing ``*`` in CSV — where the metric
says which direction is better (``slamarena.experiments.metrics`` outputs: lower or higher); every
mean that reads the same as the best (the same text at the table's three significant digits) is
marked too, so no value a reader sees as tied for best is left plain.
The CSV also carries the raw ``<column>_mean`` / ``<column>_std`` numbers.

The summary frame of a run is :func:`collect` (``summary.csv``); :func:`monte_carlo_table` is the run's NEES and NIS
averaged over the seeds (``tables/monte_carlo.*``, its columns in :data:`MONTE_CARLO_COLUMNS`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from .metrics import output_columns
from .results import atomic_write_text, load_npz, read_json

if TYPE_CHECKING:
    from .cellspec import CellOutcome
    from .config import ExperimentConfig
    from .plan import Cell

__all__ = [
    "aggregate",
    "format_number",
    "format_cells",
    "collect",
    "monte_carlo_table",
    "MONTE_CARLO_COLUMNS",
    "to_markdown",
    "to_latex",
    "write_tables",
    "write_frame",
    "default_columns",
    "table_specs",
]

_DEFAULTS = (
    "ate.rmse",
    "ate.heading_rmse",
    "rpe.trans_rmse",
    "rpe.rot_rmse",
    "nees.mean_over_dof",
    "nees.in_band",
    "nis.mean_over_dof",
    "map.rmse",
    "relations.trans_mean",
    "cost.step_median",
    "cost.wall",
    "cost.peak_rss_mb",
)


def default_columns(enabled) -> list[str]:
    """The default summary table's columns for the enabled metrics."""
    return [c for c in _DEFAULTS if c.split(".")[0] in enabled] or ["cost.wall"]


def table_specs(tables: list, enabled) -> list[dict]:
    """The tables a run writes: the config's ``tables`` (specs or their dicts), or one ``summary`` table of the
    default columns of the ``enabled`` metrics."""
    specs = [t if isinstance(t, dict) else t.model_dump() for t in tables]
    return specs or [{"name": "summary", "columns": default_columns(enabled)}]


def format_number(x: float) -> str:
    if not np.isfinite(x):
        return "–"
    if x == 0:
        return "0"
    if float(x).is_integer() and abs(x) < 1e7:  # a count (landmarks, rows, iterations) in full, not 2.72e+03
        return str(int(x))
    return f"{x:.3g}" if 1e-3 <= abs(x) < 1e4 else f"{x:.2e}"


def aggregate(frame: pd.DataFrame, columns: list[str]) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(means, stds, best) per (dataset, estimator) for ``columns``; ``best`` is a bool frame."""
    ok = frame[frame["status"] == "ok"] if "status" in frame else frame
    cols = [c for c in columns if c in ok.columns]
    grouped = ok.groupby(["dataset", "estimator"], sort=False)[cols]
    means, stds = grouped.mean(), grouped.std(ddof=1)
    counts = grouped.size().rename("n")
    means = means.reindex(columns=columns)
    stds = stds.reindex(columns=columns)
    better = output_columns()
    best = pd.DataFrame(False, index=means.index, columns=columns)
    for col in columns:
        direction = better.get(col, (None,))[0]
        if direction is None:
            continue
        for ds, block in means[col].groupby(level="dataset", sort=False):
            if block.notna().sum() < 2:
                continue
            target = format_number(block.min() if direction == "lower" else block.max())
            best.loc[block.index[block.map(format_number) == target], col] = True
    means.insert(0, "n", counts)
    return means, stds, best


PUBLISHED = " (published)"


def with_published(
    means: pd.DataFrame, stds: pd.DataFrame, best: pd.DataFrame, published
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Append the published reference rows (config ``published:``) for the datasets and columns of a table: each
    row ``(dataset, "<label> (published)")`` with the quoted values, n = 0, never marked best, after our rows of
    that dataset (a dataset this run has no row for gets none)."""
    ours = set(means.index.get_level_values(0))
    rows = []
    for row in published:
        spec = row if isinstance(row, dict) else row.model_dump()
        for dataset, values in spec["values"].items():
            shown = {c: v for c, v in values.items() if c in best.columns}
            if shown and dataset in ours:
                rows.append(((dataset, spec["label"] + PUBLISHED), shown))
    if not rows:
        return means, stds, best
    index = pd.MultiIndex.from_tuples([key for key, _ in rows], names=means.index.names)
    extra = pd.DataFrame([{**values, "n": 0} for _, values in rows], index=index).reindex(columns=means.columns)
    means = pd.concat([means, extra])
    stds = pd.concat([stds, pd.DataFrame(np.nan, index=index, columns=stds.columns)])
    best = pd.concat([best, pd.DataFrame(False, index=index, columns=best.columns)])
    order = sorted(
        range(len(means)),
        key=lambda k: (list(dict.fromkeys(means.index.get_level_values(0))).index(means.index[k][0]), k),
    )
    return means.iloc[order], stds.iloc[order], best.iloc[order]


def format_cells(means: pd.DataFrame, stds: pd.DataFrame, best: pd.DataFrame, mark) -> pd.DataFrame:
    out = pd.DataFrame(index=means.index)
    out["n"] = [str(int(n)) if n else "–" for n in means["n"]]
    for col in best.columns:
        texts = []
        for idx in means.index:
            m, s, n = means.at[idx, col], stds.at[idx, col], means.at[idx, "n"]
            text = format_number(m) if (n < 2 or not np.isfinite(s)) else f"{format_number(m)} ± {format_number(s)}"
            texts.append(mark(text) if best.at[idx, col] else text)
        out[col] = texts
    return out.reset_index()


_TEX = {"\\": r"\textbackslash{}", "_": r"\_", "%": r"\%", "&": r"\&", "#": r"\#", "$": r"\$", "{": r"\{", "}": r"\}"}


def _tex_escape(s: str) -> str:
    return re.sub(r"[\\_%&#${}]", lambda m: _TEX[m.group()], s)


def _markdown(cells: pd.DataFrame, text_columns: int = 2) -> str:
    header = "| " + " | ".join(cells.columns) + " |"
    rule = "|" + "|".join("---" if k < text_columns else "---:" for k in range(len(cells.columns))) + "|"
    rows = ["| " + " | ".join(str(v) for v in row) + " |" for row in cells.itertuples(index=False)]
    return "\n".join([header, rule, *rows]) + "\n"


def _latex(cells: pd.DataFrame, text_columns: int = 2) -> str:
    """A booktabs tabular; text columns (and the header) are escaped here, once; the others are already LaTeX."""
    lines = [
        f"\\begin{{tabular}}{{{'l' * text_columns + 'r' * (len(cells.columns) - text_columns)}}}",
        "\\toprule",
        " & ".join(_tex_escape(str(c)) for c in cells.columns) + r" \\",
        "\\midrule",
    ]
    for row in cells.itertuples(index=False):
        lines.append(
            " & ".join(_tex_escape(str(v)) if k < text_columns else str(v) for k, v in enumerate(row)) + r" \\"
        )
    lines += ["\\bottomrule", "\\end{tabular}"]
    return "\n".join(lines) + "\n"


def to_markdown(means, stds, best, published=()) -> str:
    """The table, then what each column is (from the metric's outputs) and where published rows come from."""
    described = output_columns()
    legend = "".join(f"- `{c}`: {described[c][1]}\n" for c in best.columns if c in described)
    sources = "".join(
        f"- {r['label']}{PUBLISHED}: {r['citation']}\n"
        for r in (p if isinstance(p, dict) else p.model_dump() for p in published)
        if any(r["label"] + PUBLISHED == e for e in means.index.get_level_values(1))
    )
    return (
        _markdown(format_cells(means, stds, best, lambda s: f"**{s}**"))
        + "\nn: seeds; mean ± std over seeds; best per dataset in bold"
        + ("; rows marked (published) quote the paper, n –" if sources else "")
        + ".\n\n"
        + legend
        + sources
    )


def to_latex(means, stds, best, published=()) -> str:
    cells = format_cells(means, stds, best, lambda s: f"\\textbf{{{s}}}")
    return _latex(cells.map(lambda v: str(v).replace(" ± ", r" $\pm$ ").replace("–", "--")))


def to_csv(means, stds, best, published=()) -> str:
    cells = format_cells(means, stds, best, lambda s: f"{s}*")
    raw = pd.concat([means.drop(columns="n").add_suffix("_mean"), stds.add_suffix("_std")], axis=1).reset_index(
        drop=True
    )
    return pd.concat([cells, raw], axis=1).to_csv(index=False)


def write_tables(frame: pd.DataFrame, tables, directory: Path, published=()) -> list[Path]:
    """Write each table spec (a dict: ``name``, ``columns``, ``formats``; :func:`table_specs`) in its formats, with the
    published reference rows that quote its columns (:func:`with_published`); returns the paths."""
    directory = Path(directory)
    written = []
    for spec in tables:
        means, stds, best = with_published(*aggregate(frame, spec["columns"]), published)
        render = {"md": to_markdown, "csv": to_csv, "tex": to_latex}
        for fmt in spec.get("formats", ["md", "csv", "tex"]):
            path = directory / f"{spec['name']}.{fmt}"
            atomic_write_text(path, render[fmt](means, stds, best, published))
            written.append(path)
    return written


def write_frame(frame: pd.DataFrame, stem: Path) -> list[Path]:
    """A plain frame (one row per group, nothing to average) in the three formats."""
    stem = Path(stem)
    shown = frame.map(lambda v: format_number(v) if isinstance(v, float) else v)
    paths = [stem.with_suffix(".md"), stem.with_suffix(".csv"), stem.with_suffix(".tex")]
    atomic_write_text(paths[0], _markdown(shown))
    atomic_write_text(paths[1], frame.to_csv(index=False))
    numbers = shown.iloc[:, 2:].map(lambda v: _tex_escape(str(v)))  # the text columns are escaped by _latex
    atomic_write_text(paths[2], _latex(pd.concat([shown.iloc[:, :2], numbers], axis=1)))
    return paths


def collect(config: ExperimentConfig, cells: list[Cell], failures: dict[str, CellOutcome]):
    """The summary frame: one row per cell, metric scalars flattened to ``<metric>.<output>``."""
    rows = []
    for cell in cells:
        ds, es = config.datasets[cell.dataset], config.estimators[cell.estimator]
        row = {
            "dataset": config.dataset_labels()[cell.dataset],
            "estimator": config.estimator_labels()[cell.estimator],
            "seed": cell.seed,
            "dataset_name": ds.name,
            "method": es.name,
        }
        if cell.id in failures:
            row.update(
                status=failures[cell.id].status,
                error=failures[cell.id].error,
                traceback=failures[cell.id].traceback,
            )
        elif cell.finished():
            info = read_json(cell.dir / "metrics.json")
            row.update(status="ok", error="", traceback="")
            for metric, values in info["metrics"].items():
                for key, value in values.items():
                    row[f"{metric}.{key}"] = value
            row["skipped"] = "; ".join(f"{k}: {v}" for k, v in info.get("skipped", {}).items())
        else:
            row.update(status="missing", error="no result (the run was interrupted?)", traceback="")
        rows.append(row)
    return pd.DataFrame(rows)


#: the columns of ``tables/monte_carlo.*`` (:func:`monte_carlo_table`) and what each is
MONTE_CARLO_COLUMNS = {
    "dataset": "dataset label",
    "estimator": "method label",
    "statistic": "nees (pose NEES, 3 degrees of freedom) or nis (the innovations of one stamp summed)",
    "runs": "N, the seeds averaged",
    "stamps": "stamps all N runs share (with equal dimension), where the average is taken",
    "mean_over_dof": "mean over those stamps of the N-run average divided by its degrees of freedom (1 for a consistent filter)",
    "in_band": "fraction of those stamps whose N-run average lies inside the two-sided N-run χ² band",
    "early_over_dof": "the same mean over the first 10 % of the time those stamps span (before any drift)",
    "late_over_dof": "the same mean over the last 10 % of that time (a filter that degrades over the run rises here)",
    "band_lo_over_dof": "the band's lower end divided by the degrees of freedom (mean over the stamps)",
    "band_hi_over_dof": "the band's upper end divided by the degrees of freedom (mean over the stamps)",
}


def monte_carlo_table(config: ExperimentConfig, cells: list[Cell]):
    """Per (dataset, method): NEES and NIS averaged over the seeds at shared stamps, with the
    N-run χ² band (:func:`slamarena.experiments.metrics.consistency.monte_carlo`); one row per statistic."""
    from .metrics.consistency import monte_carlo, nis_per_stamp
    from .metrics.reference import MetricUnavailable
    from .metrics.series import Series

    enabled = config.enabled_metrics()
    groups: dict[tuple[str, str, str], list] = {}
    for cell in cells:
        if not cell.finished() or not (cell.dir / "series.npz").exists():
            continue
        series = load_npz(cell.dir / "series.npz")
        key = (config.dataset_labels()[cell.dataset], config.estimator_labels()[cell.estimator])
        if Series.NEES in series:
            groups.setdefault(key + ("nees",), []).append(
                (series[Series.NEES_T], series[Series.NEES], np.full(series[Series.NEES_T].shape, 3.0))
            )
        if Series.NIS in series:
            groups.setdefault(key + ("nis",), []).append(
                nis_per_stamp(series[Series.NIS_T], series[Series.NIS], series[Series.NIS_DOF])
            )
    rows = []
    for (ds, es, stat), runs in groups.items():
        try:
            mc = monte_carlo(runs, probability=enabled[stat].probability)
        except MetricUnavailable:
            continue
        ratio, t = mc["mean"] / mc["dof"], mc["t"]
        span = t[-1] - t[0]
        rows.append(
            {
                "dataset": ds,
                "estimator": es,
                "statistic": stat,
                "runs": mc["runs"],
                "stamps": int(t.size),
                "mean_over_dof": float(np.mean(ratio)),
                "in_band": mc["in_band"],
                "early_over_dof": float(np.mean(ratio[t <= t[0] + 0.1 * span])),
                "late_over_dof": float(np.mean(ratio[t >= t[-1] - 0.1 * span])),
                "band_lo_over_dof": float(np.mean(mc["lo"] / mc["dof"])),
                "band_hi_over_dof": float(np.mean(mc["hi"] / mc["dof"])),
            }
        )
    return pd.DataFrame(rows)
