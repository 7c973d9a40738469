"""The report of an experiment: ``slamarena report RESULTS_DIR [OTHER]`` and ``slamarena run … --report``.

One self-contained HTML file — the style inline, every figure embedded as a ``data:`` URI, no script, nothing
fetched when it is opened: it works offline and can be mailed — and its Markdown twin (figures linked relative to
it), written from the results directory alone (:mod:`slamarena.experiments.results`):

1. the title and description; the run: command, start, end, duration, cells (ok / failed / total), git revision,
   machine; the package versions;
2. every table of the config (or the default summary table) and the Monte Carlo consistency table, each with a
   caption that says what every column is (the metric's description of its output, :func:`output_columns`), with
   which metric settings it was computed and how the cells aggregate (:mod:`slamarena.experiments.tables`: mean ± std
   over the seeds, best per dataset in bold); the config's published reference rows (``published:``, a list of
   ``{label, citation, values: {dataset label: {column: number}}}``) beside ours, marked "(published)", with their
   citation;
3. every figure of ``figures/`` with the caption its module wrote beside it (``<stem>.caption``), and the kinds not
   drawn with the reason;
4. the failed cells with their error and traceback;
5. the config as run and the resolved parameters of every dataset and method.

Two results directories (``slamarena report A B``: one config, two code versions) give one report with A and B side
by side: the run facts and versions, every table cell as A | B, the figures in pairs, the failed cells of each;
every value that differs is highlighted, and a table value of B is marked better or worse than A's by the metric's
direction.

The document is built once as a list of blocks (:class:`Heading`, :class:`Text`, :class:`Table`, :class:`Figures`,
:class:`Code`) and rendered twice (:func:`to_html`, :func:`to_markdown`), so the two files say the same.
"""

from __future__ import annotations

import base64
import difflib
import html
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from slamarena.errors import UserError

from .results import CAPTION_SUFFIX, MANIFEST, SUMMARY, atomic_write_text

__all__ = ["write_report", "build", "build_comparison", "to_html", "to_markdown", "Results", "ResultsError", "REPORT"]

REPORT = "report"  # <results>/report.html and report.md
NEES_COLUMN = "nees.mean_over_dof"


class ResultsError(UserError, ValueError):
    """A directory that is not a readable results directory (the message names the file)."""


# ---------------------------------------------------------------------------- the document
@dataclass
class Cell:
    text: str
    marks: frozenset = frozenset()  # best, published, changed, better, worse


@dataclass
class Heading:
    level: int
    text: str
    anchor: str = ""


@dataclass
class Text:
    text: str
    items: list[str] = field(default_factory=list)  # a bullet list after the paragraph
    links: dict[str, str] = field(default_factory=dict)  # a fragment of the text or items → the address it links to


@dataclass
class Table:
    anchor: str
    header: list[str]
    rows: list[list[Cell]]
    caption: Text | None = None


@dataclass
class Figure:
    stem: str
    path: Path | None  # the PNG (None: absent on this side)
    caption: str


@dataclass
class Figures:
    anchor: str
    figures: list[Figure]  # drawn side by side (one per results directory)


@dataclass
class Code:
    text: str
    summary: str = ""  # folded under this summary in HTML
    marks: frozenset = frozenset()


# ---------------------------------------------------------------------------- reading a results directory
@dataclass
class Results:
    dir: Path
    manifest: dict
    frame: object | None  # the summary frame (pandas), None if the run wrote none

    @classmethod
    def load(cls, directory: str | Path) -> Results:
        import pandas as pd

        directory = Path(directory)
        path = directory / MANIFEST
        if not path.is_file():
            raise ResultsError(f"{directory}: not a results directory (no {MANIFEST}; `slamarena run` writes one)")
        try:
            manifest = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ResultsError(f"{path}: unreadable manifest: {exc}") from None
        if not isinstance(manifest, dict):
            raise ResultsError(f"{path}: a manifest is a JSON object")
        frame = None
        if (directory / SUMMARY).is_file():
            try:
                frame = pd.read_csv(directory / SUMMARY, keep_default_na=False, na_values=[""])
            except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
                raise ResultsError(f"{directory / SUMMARY}: unreadable summary: {exc}") from None
        return cls(directory, manifest, frame)

    @property
    def config(self) -> dict:
        return self.manifest.get("config") or {}

    @property
    def name(self) -> str:
        return self.manifest.get("experiment") or self.config.get("name") or self.dir.name

    def metrics(self) -> dict[str, dict]:
        """The enabled metrics and their settings, as run."""
        return {k: v for k, v in (self.config.get("metrics") or {}).items() if v is not None}

    def table_specs(self) -> list[dict]:
        from .tables import table_specs

        return table_specs(self.config.get("tables") or [], self.metrics())

    def published(self) -> list[dict]:
        return list(self.config.get("published") or [])

    def figures(self) -> list[Figure]:
        out = []
        for png in sorted((self.dir / "figures").glob("*.png"), key=_figure_order):
            caption = png.with_suffix(CAPTION_SUFFIX)
            out.append(
                Figure(
                    png.stem,
                    png,
                    caption.read_text(encoding="utf-8").strip() if caption.is_file() else "(no caption recorded)",
                )
            )
        return out

    def failed(self):
        if self.frame is None or "status" not in self.frame:
            return None
        return self.frame[self.frame["status"] != "ok"]

    def monte_carlo(self):
        import pandas as pd

        path = self.dir / "tables" / "monte_carlo.csv"
        return pd.read_csv(path) if path.is_file() else None


def _figure_order(path: Path):
    from .config import FIGURES

    kind = path.stem.split("_")[0]
    return (FIGURES.index(kind) if kind in FIGURES else len(FIGURES), path.stem)


# ---------------------------------------------------------------------------- pieces
def _fmt(x) -> str:
    from .tables import format_number as fmt

    return fmt(float(x)) if isinstance(x, (int, float, np.number)) and not isinstance(x, bool) else str(x)


def _settings(params: dict | None) -> str:
    return ", ".join(f"{k}={json.dumps(v)}" for k, v in (params or {}).items()) or "defaults"


def _facts(r: Results) -> list[tuple[str, str]]:
    m = r.manifest
    cells = m.get("cells") or {}
    failed = m.get("failed") or []
    machine = m.get("machine") or {}
    state = (
        "finished"
        if m.get("finished")
        else ("interrupted " + json.dumps(m["interrupted"]) if m.get("interrupted") else "not finished")
    )
    return [
        ("results", str(r.dir.resolve())),
        ("command", " ".join(m.get("command") or [])),
        ("started", str(m.get("started"))),
        ("finished", f"{m.get('finished')} ({state})"),
        ("duration", f"{m['duration_s']:.1f} s" if isinstance(m.get("duration_s"), (int, float)) else "–"),
        (
            "cells",
            f"{cells.get('total', '–')} total, {cells.get('to_run', '–')} run, {cells.get('cached', '–')} cached, {len(failed)} failed",
        ),
        ("git revision", str(m.get("git_revision"))),
        ("machine", ", ".join(f"{k} {v}" for k, v in machine.items())),
        ("jobs / scheduler", f"{m.get('jobs')} / {m.get('scheduler') or 'local'}"),
    ]


#: the research page that explains a method's known inconsistency: registry name → (what it is, page, section title)
KNOWN_INCONSISTENCY = {
    "fastslam": (
        "FastSLAM's known over-confidence, expected and not a defect: resampling depletes the path hypotheses, so the "
        "particle cloud forgets the uncertainty of the past and its covariance shrinks below the error; more particles "
        "delay it, none prevent it (Bailey, Nieto & Nebot 2006, reproduced here)",
        "research/notebook/2026-11-23-fastslam-consistency.md",
        "5.2 Consistency and cost against accuracy on sim:landmarks",
    ),
}
#: NEES / dof above this is flagged: the covariance understates the error by more than √2 in standard deviation
OVER_CONFIDENT = 2.0
#: the checkout whose research pages a report links to (when they exist there: not in an installed wheel)
CHECKOUT = Path(__file__).resolve().parents[1]


def _anchor(title: str) -> str:
    """The anchor of a Markdown heading as GitHub and most renderers make it."""
    return "-".join(re.sub(r"[^\w\s-]", "", title.lower()).split(" "))


def _consistency_notes(r: Results, rows) -> tuple[list[str], dict[str, str]]:
    """Caption items for the rows ``(dataset, method label, NEES / dof)`` that are over-confident
    (:data:`OVER_CONFIDENT`) and whose method has a known explanation (:data:`KNOWN_INCONSISTENCY`), with the links
    to it."""
    from .config import sanitize

    names = {e.get("label") or sanitize(e["name"]): e["name"] for e in r.config.get("estimators") or []}
    items, links = [], {}
    for dataset, method, value in rows:
        known = KNOWN_INCONSISTENCY.get(names.get(method))
        if known is None or not np.isfinite(value) or value <= OVER_CONFIDENT:
            continue
        what, page, section = known
        where = f"{page} § {section}"
        items.append(
            f"{method} on {dataset}: NEES / dof = {_fmt(value)} (a consistent filter gives 1; its error is "
            f"{np.sqrt(value):.1f}× the standard deviation it reports). {what}; explained in {where}."
        )
        if (CHECKOUT / page).is_file():
            links[where] = f"{(CHECKOUT / page).as_uri()}#{_anchor(section)}"
    return items, links


def _caption(r: Results, columns: list[str], published: list[dict]) -> Text:
    from .metrics import output_columns

    described = output_columns()
    metrics = r.metrics()
    items = []
    for c in columns:
        metric = c.split(".")[0]
        better, what = described.get(c, (None, "(not a metric output of this version)"))
        direction = {"lower": "lower is better", "higher": "higher is better"}.get(better, "no better direction")
        items.append(f"{c}: {what}; {direction}; metric {metric} with {_settings(metrics.get(metric))}.")
    for row in published:
        items.append(f"{row.get('label')} (published): {row.get('citation', 'no citation given')}")
    return Text(
        "n: seeds. Each value is the mean ± standard deviation over the seeds of a dataset and method "
        "(std with ddof = 1; one seed shows the mean alone); in bold the best mean within each dataset, and every mean "
        "that reads the same, for columns with a better direction."
        + (
            " Rows marked (published) are reference values from the literature, not computed here." if published else ""
        ),
        items,
    )


def _table_cells(r: Results, columns: list[str], published: list[dict]):
    """(means, rows of Cells, the published rows quoted) of a table spec's columns, through the tables module's
    aggregation with the published rows (:func:`~slamarena.experiments.tables.with_published`)."""
    from .tables import PUBLISHED, aggregate, format_cells, with_published

    means, stds, best = with_published(*aggregate(r.frame, columns), published)
    frame = format_cells(means, stds, best, lambda s: Cell(s, frozenset({"best"})))
    rows = []
    for row in frame.itertuples(index=False):
        quoted = str(row[1]).endswith(PUBLISHED)
        rows.append(
            [
                v if isinstance(v, Cell) else Cell(str(v), frozenset({"published"}) if quoted else frozenset())
                for v in row
            ]
        )
    shown = set(means.index.get_level_values(1))
    return means, rows, [p for p in published if p.get("label", "") + PUBLISHED in shown]


def _monte_carlo_table(r: Results) -> Table | None:
    from .tables import MONTE_CARLO_COLUMNS

    mc = r.monte_carlo()
    if mc is None or not len(mc):
        return None
    header = list(mc.columns)
    rows = [[Cell(_fmt(v)) for v in row] for row in mc.itertuples(index=False)]
    caption = Text(
        "Consistency over the Monte Carlo seeds: per dataset, method and statistic (pose NEES; NIS with the innovations "
        "of one stamp summed), the value averaged over the N runs at the stamps they all share, against the N-run "
        "two-sided band [χ²_{N·dof}(α/2), χ²_{N·dof}(1 − α/2)] / N.",
        [f"{c}: {MONTE_CARLO_COLUMNS[c]}" for c in header if c in MONTE_CARLO_COLUMNS],
    )
    nees = mc[mc["statistic"] == "nees"]
    notes, caption.links = _consistency_notes(r, zip(nees["dataset"], nees["estimator"], nees["mean_over_dof"]))
    caption.items += notes
    return Table("table-monte_carlo", header, rows, caption)


def _failed_table(r: Results, anchor: str) -> tuple[Table | None, list[Code]]:
    failed = r.failed()
    if failed is None or not len(failed):
        return None, []
    rows, traces = [], []
    for f in (
        failed.reindex(columns=["dataset", "estimator", "seed", "status", "error", "traceback"])
        .astype(object)
        .fillna("")
        .itertuples(index=False)
    ):
        rows.append([Cell(str(x)) for x in (f.dataset, f.estimator, f.seed, f.status, f.error)])
        if str(f.traceback).strip():
            traces.append(Code(str(f.traceback), summary=f"traceback of {f.dataset}/{f.estimator}/{f.seed}"))
    return Table(anchor, ["dataset", "method", "seed", "status", "error"], rows), traces


def _yaml(obj) -> str:
    import yaml

    return yaml.safe_dump(obj, sort_keys=False, allow_unicode=True, width=110)


def _not_drawn(r: Results) -> Text | None:
    errors = r.manifest.get("figure_errors") or {}
    return Text("Figure kinds not drawn:", [f"{k}: {v}" for k, v in errors.items()]) if errors else None


# ---------------------------------------------------------------------------- one results directory
def build(r: Results) -> tuple[str, list]:
    """The report of one results directory: (title, blocks)."""
    title = f"{r.name} — slamarena report"
    blocks: list = [Heading(1, title)]
    if r.config.get("description"):
        blocks.append(Text(r.config["description"]))
    blocks += [
        Heading(2, "Run", "run"),
        Table("table-run", ["fact", "value"], [[Cell(k), Cell(v)] for k, v in _facts(r)]),
        Heading(2, "Versions", "versions"),
        Table(
            "table-versions",
            ["package", "version"],
            [[Cell(k), Cell(str(v))] for k, v in (r.manifest.get("versions") or {}).items()],
        ),
    ]
    blocks.append(Heading(2, "Tables", "tables"))
    if r.frame is None:
        blocks.append(Text(f"No {SUMMARY}: the run did not finish, so there are no tables."))
    else:
        published = r.published()
        for spec in r.table_specs():
            columns = list(spec["columns"])
            means, rows, cited = _table_cells(r, columns, published)
            caption = _caption(r, columns, cited)
            if NEES_COLUMN in columns:
                notes, caption.links = _consistency_notes(
                    r, ((ds, method, v) for (ds, method), v in means[NEES_COLUMN].items())
                )
                caption.items += notes
            blocks += [
                Heading(3, spec["name"]),
                Table(f"table-{spec['name']}", ["dataset", "method", "n", *columns], rows, caption),
            ]
        mc = _monte_carlo_table(r)
        if mc is not None:
            blocks += [Heading(3, "monte_carlo"), mc]
    blocks.append(Heading(2, "Figures", "figures"))
    figures = r.figures()
    blocks += [Figures(f"figure-{f.stem}", [f]) for f in figures] or [Text("No figures were drawn.")]
    not_drawn = _not_drawn(r)
    if not_drawn:
        blocks.append(not_drawn)
    blocks.append(Heading(2, "Failed cells", "failed"))
    table, traces = _failed_table(r, "table-failed")
    blocks += (
        [table, *traces]
        if table
        else [Text("None: every cell finished." if r.frame is not None else "Unknown (no summary).")]
    )
    blocks += [
        Heading(2, "Configuration as run", "config"),
        Code(_yaml(r.config)),
        Heading(3, "Resolved parameters (defaults filled in)"),
        Code(_yaml(r.manifest.get("resolved_params") or {})),
    ]
    return title, blocks


# ---------------------------------------------------------------------------- two results directories
def _pair(a: str, b: str) -> list[Cell]:
    changed = frozenset({"changed"}) if a != b else frozenset()
    return [Cell(a), Cell(b, changed)]


def _compare_table(a: Results, b: Results, spec: dict) -> Table:
    from .metrics import output_columns

    described = output_columns()
    columns = list(spec["columns"])
    (ma, ra, _), (mb, rb, _) = (_table_cells(r, columns, []) for r in (a, b))
    by_key = [{(row[0].text, row[1].text): row for row in rows} for rows in (ra, rb)]
    keys = list(by_key[0]) + [k for k in by_key[1] if k not in by_key[0]]
    rows = []
    for key in keys:
        row = [Cell(key[0]), Cell(key[1])]
        for k in range(2, 3 + len(columns)):
            ta, tb = (by_key[s][key][k].text if key in by_key[s] else "" for s in (0, 1))
            cells = _pair(ta, tb)
            if "changed" in cells[1].marks and k >= 3 and key in by_key[0] and key in by_key[1]:
                better = described.get(columns[k - 3], (None,))[0]
                va, vb = ma.at[key, columns[k - 3]], mb.at[key, columns[k - 3]]
                if better and np.isfinite(va) and np.isfinite(vb) and va != vb:
                    cells[1] = Cell(tb, cells[1].marks | {"better" if (vb < va) == (better == "lower") else "worse"})
            row += cells
        rows.append(row)
    header = ["dataset", "method", "n A", "n B"] + [f"{c} {side}" for c in columns for side in ("A", "B")]
    caption = _caption(a, columns, [])
    caption.text = (
        "A and B side by side; a value of B that differs from A's is highlighted, marked better or worse where the "
        "metric has a direction. " + caption.text
    )
    return Table(f"table-{spec['name']}", header, rows, caption)


def build_comparison(a: Results, b: Results) -> tuple[str, list]:
    """The side-by-side report of two results directories (A, B): (title, blocks)."""
    title = f"{a.name}: A = {a.manifest.get('git_revision')} vs B = {b.manifest.get('git_revision')} — slamarena report"
    facts_a, facts_b = dict(_facts(a)), dict(_facts(b))
    blocks: list = [
        Heading(1, title),
        Text(f"A: {a.dir.resolve()}", []),
        Text(f"B: {b.dir.resolve()}"),
        Heading(2, "Run", "run"),
        Table("table-run", ["fact", "A", "B"], [[Cell(k), *_pair(facts_a[k], facts_b.get(k, ""))] for k in facts_a]),
    ]
    va, vb = a.manifest.get("versions") or {}, b.manifest.get("versions") or {}
    blocks += [
        Heading(2, "Versions", "versions"),
        Table(
            "table-versions",
            ["package", "A", "B"],
            [[Cell(k), *_pair(str(va.get(k, "–")), str(vb.get(k, "–")))] for k in dict.fromkeys([*va, *vb])],
        ),
    ]
    blocks.append(Heading(2, "Configuration", "config"))
    if a.config == b.config:
        blocks.append(Text("A and B ran the same config (below)."))
    else:
        diff = "".join(
            difflib.unified_diff(_yaml(a.config).splitlines(True), _yaml(b.config).splitlines(True), "A", "B")
        )
        blocks += [Text("The configs differ (unified diff, A → B):"), Code(diff, marks=frozenset({"changed"}))]
    blocks.append(Heading(2, "Tables", "tables"))
    if a.frame is None or b.frame is None:
        blocks.append(Text(f"No {SUMMARY} in {'A' if a.frame is None else 'B'}: no tables to compare."))
    else:
        names = {s["name"] for s in a.table_specs()}
        for spec in a.table_specs() + [s for s in b.table_specs() if s["name"] not in names]:
            blocks += [Heading(3, spec["name"]), _compare_table(a, b, spec)]
    blocks.append(Heading(2, "Figures", "figures"))
    fa, fb = ({f.stem: f for f in r.figures()} for r in (a, b))
    for stem in dict.fromkeys([*fa, *fb]):
        pair = [
            fa.get(stem) or Figure(stem, None, "(not drawn in A)"),
            fb.get(stem) or Figure(stem, None, "(not drawn in B)"),
        ]
        blocks.append(Figures(f"figure-{stem}", pair))
    blocks.append(Heading(2, "Failed cells", "failed"))
    for side, r in (("A", a), ("B", b)):
        table, traces = _failed_table(r, f"table-failed-{side}")
        blocks += [Heading(3, side), *([table, *traces] if table else [Text("None.")])]
    return title, blocks


# ---------------------------------------------------------------------------- rendering
SCREEN = 0.75  # CSS pixels per PNG pixel: a one-column figure (700 px at 200 dpi) is 525 px wide on screen
_CSS = """
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", sans-serif; max-width: 1200px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; margin-top: 2em; } h3 { margin-top: 1.5em; }
table { border-collapse: collapse; margin: .5em 0; font-variant-numeric: tabular-nums; }
th, td { border-bottom: 1px solid #ddd; padding: .2em .6em; text-align: right; vertical-align: top; white-space: nowrap; }
th:nth-child(-n+2), td:nth-child(-n+2) { text-align: left; }
.best { font-weight: bold; } .published { font-style: italic; color: #555; background: #f4f4f4; }
.changed { background: #fff3b0; } .better { background: #c8ecc9; } .worse { background: #f7c6c5; }
.caption { font-size: .9em; color: #444; max-width: 70em; } .caption ul { margin: .2em 0; }
.table-scroll { overflow-x: auto; max-width: 100%; } .caption a { color: inherit; }
.figures { display: flex; gap: 1em; margin: 1em 0; } figure { margin: 0; flex: 1; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; display: block; }
pre { background: #f6f6f6; padding: .6em; overflow-x: auto; font-size: .85em; } pre.changed { background: #fff3b0; }
"""


def _esc(s: str) -> str:
    return html.escape(str(s), quote=True)


def _linked(t: Text, s: str) -> str:
    """``s`` escaped, each fragment of ``t.links`` in it a link."""
    out = _esc(s)
    for fragment, href in t.links.items():
        out = out.replace(_esc(fragment), f'<a href="{_esc(href)}">{_esc(fragment)}</a>')
    return out


def _html_text(t: Text, cls: str = "") -> str:
    items = "".join(f"<li>{_linked(t, i)}</li>" for i in t.items)
    return f'<div class="{cls}"><p>{_linked(t, t.text)}</p>' + (f"<ul>{items}</ul>" if items else "") + "</div>"


def _img(f: Figure) -> str:
    """The PNG embedded as a data: URI, shown at ``SCREEN`` of its pixel width (its width is in the PNG header)."""
    data = f.path.read_bytes()
    width = int.from_bytes(data[16:20], "big")
    src = f"data:image/png;base64,{base64.b64encode(data).decode('ascii')}"
    return f'<img src="{src}" alt="{_esc(f.stem)}" style="width: {width * SCREEN:.0f}px">'


def to_html(title: str, blocks: list) -> str:
    """The blocks as one self-contained HTML page (no external resource, no script)."""
    out = [
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_esc(title)}</title><style>{_CSS}</style></head><body>",
    ]
    for b in blocks:
        if isinstance(b, Heading):
            out.append(f"<h{b.level}{f' id={_esc(b.anchor)!r}' if b.anchor else ''}>{_esc(b.text)}</h{b.level}>")
        elif isinstance(b, Text):
            out.append(_html_text(b))
        elif isinstance(b, Table):
            head = "".join(f"<th>{_esc(h)}</th>" for h in b.header)
            body = "".join(
                "<tr>"
                + "".join(
                    f'<td class="{" ".join(sorted(c.marks))}">{_esc(c.text)}</td>'
                    if c.marks
                    else f"<td>{_esc(c.text)}</td>"
                    for c in row
                )
                + "</tr>"
                for row in b.rows
            )
            out.append(
                f'<div class="table-scroll"><table id="{_esc(b.anchor)}"><thead><tr>{head}</tr></thead>'
                f"<tbody>{body}</tbody></table></div>"
            )
            if b.caption:
                out.append(_html_text(b.caption, "caption"))
        elif isinstance(b, Figures):
            figs = []
            for f in b.figures:
                img = _img(f) if f.path is not None else ""
                figs.append(
                    f'<figure>{img}<figcaption class="caption"><b>{_esc(f.stem)}</b>. {_esc(f.caption)}</figcaption></figure>'
                )
            out.append(f'<div class="figures" id="{_esc(b.anchor)}">{"".join(figs)}</div>')
        elif isinstance(b, Code):
            cls = f' class="{" ".join(sorted(b.marks))}"' if b.marks else ""
            pre = f"<pre{cls}>{_esc(b.text)}</pre>"
            out.append(f"<details><summary>{_esc(b.summary)}</summary>{pre}</details>" if b.summary else pre)
    out.append("</body></html>\n")
    return "\n".join(out)


def _md_cell(c: Cell) -> str:
    text = c.text.replace("|", "\\|").replace("\n", " ")
    if not text:
        return ""
    if "best" in c.marks or "changed" in c.marks:
        text = f"**{text}**"
    if "published" in c.marks:
        text = f"*{text}*"
    for mark in ("better", "worse"):
        if mark in c.marks:
            text += f" ({mark})"
    return text


def _md_text(t: Text) -> str:
    def linked(s: str) -> str:
        for fragment, href in t.links.items():
            s = s.replace(fragment, f"[{fragment}]({href})")
        return s

    return linked(t.text) + "\n" + "".join(f"\n- {linked(i)}" for i in t.items) + ("\n" if t.items else "")


def to_markdown(title: str, blocks: list, base: Path) -> str:
    """The blocks as Markdown; figures are linked relative to ``base`` (the Markdown file's folder)."""
    out = []
    for b in blocks:
        if isinstance(b, Heading):
            out.append("#" * b.level + " " + b.text)
        elif isinstance(b, Text):
            out.append(_md_text(b))
        elif isinstance(b, Table):
            lines = [
                "| " + " | ".join(h.replace("|", "\\|") for h in b.header) + " |",
                "|" + "|".join("---" for _ in b.header) + "|",
            ]
            lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("\n".join(lines) + ("\n\n" + _md_text(b.caption) if b.caption else ""))
        elif isinstance(b, Figures):
            for f in b.figures:
                image = (
                    f"![{f.stem}]({Path(os.path.relpath(f.path.resolve(), base)).as_posix()})\n\n"
                    if f.path is not None
                    else ""
                )
                out.append(f"{image}*{f.stem}.* {f.caption}")
        elif isinstance(b, Code):
            out.append((f"{b.summary}:\n\n" if b.summary else "") + "```\n" + b.text.rstrip("\n") + "\n```")
    return "\n\n".join(out) + "\n"


# ---------------------------------------------------------------------------- entry point
def write_report(
    results_dir: str | Path, other: str | Path | None = None, out: str | Path | None = None
) -> tuple[Path, Path]:
    """Write the HTML report and its Markdown twin; returns their paths.

    One directory: ``<results>/report.html`` and ``report.md``. Two: ``<A>/report_vs_<B's folder name>.html``
    and ``.md``. ``out`` (a path; its suffix is replaced) overrides the location.
    """
    a = Results.load(results_dir)
    if other is None:
        title, blocks = build(a)
        stem = Path(out) if out is not None else a.dir / REPORT
    else:
        b = Results.load(other)
        title, blocks = build_comparison(a, b)
        stem = Path(out) if out is not None else a.dir / f"{REPORT}_vs_{Path(other).resolve().name}"
    html_path, md_path = stem.with_suffix(".html"), stem.with_suffix(".md")
    if html_path.parent.exists() and not html_path.parent.is_dir():
        raise ResultsError(f"--out {out}: {html_path.parent} is a file, not a directory")
    atomic_write_text(html_path, to_html(title, blocks))
    atomic_write_text(md_path, to_markdown(title, blocks, md_path.parent.resolve()))
    return html_path, md_path
