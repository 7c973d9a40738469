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
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from .metrics import output_columns
from .results import atomic_write_text

__all__ = ["aggregate", "to_markdown", "to_latex", "write_tables", "write_frame", "default_columns", "table_specs"]

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


def _fmt(x: float) -> str:
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
            target = _fmt(block.min() if direction == "lower" else block.max())
            best.loc[block.index[block.map(_fmt) == target], col] = True
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


def _cells(means: pd.DataFrame, stds: pd.DataFrame, best: pd.DataFrame, mark) -> pd.DataFrame:
    out = pd.DataFrame(index=means.index)
    out["n"] = [str(int(n)) if n else "–" for n in means["n"]]
    for col in best.columns:
        texts = []
        for idx in means.index:
            m, s, n = means.at[idx, col], stds.at[idx, col], means.at[idx, "n"]
            text = _fmt(m) if (n < 2 or not np.isfinite(s)) else f"{_fmt(m)} ± {_fmt(s)}"
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
        _markdown(_cells(means, stds, best, lambda s: f"**{s}**"))
        + "\nn: seeds; mean ± std over seeds; best per dataset in bold"
        + ("; rows marked (published) quote the paper, n –" if sources else "")
        + ".\n\n"
        + legend
        + sources
    )


def to_latex(means, stds, best, published=()) -> str:
    cells = _cells(means, stds, best, lambda s: f"\\textbf{{{s}}}")
    return _latex(cells.map(lambda v: str(v).replace(" ± ", r" $\pm$ ").replace("–", "--")))


def to_csv(means, stds, best, published=()) -> str:
    cells = _cells(means, stds, best, lambda s: f"{s}*")
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
    shown = frame.map(lambda v: _fmt(v) if isinstance(v, float) else v)
    paths = [stem.with_suffix(".md"), stem.with_suffix(".csv"), stem.with_suffix(".tex")]
    atomic_write_text(paths[0], _markdown(shown))
    atomic_write_text(paths[1], frame.to_csv(index=False))
    numbers = shown.iloc[:, 2:].map(lambda v: _tex_escape(str(v)))  # the text columns are escaped by _latex
    atomic_write_text(paths[2], _latex(pd.concat([shown.iloc[:, :2], numbers], axis=1)))
    return paths
