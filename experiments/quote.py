"""Pages that quote results: ``slamarena results [PAGE] [--results ROOT]`` regenerates every number a page quotes.

A page (``research/results.md`` by default) is ordinary Markdown whose quoted tables and numbers sit between markers
naming where they come from; everything outside the markers is prose, left as written. Two markers::

    <!-- table: consistency/monte_carlo rows=*/*/nees columns=mean_over_dof,late_over_dof,in_band -->
    (replaced by: the command, the run's provenance, the table, its column legend, the failed cells)
    <!-- /table -->

    the standard EKF ends at <!-- value: consistency/monte_carlo hard/ekf_slam/nees late_over_dof -->4.07<!-- /value -->

The source ``EXPERIMENT/TABLE`` is ``ROOT/EXPERIMENT/tables/TABLE.md``, as ``slamarena run EXPERIMENT`` writes it
(:mod:`slamarena.experiments.tables`; ROOT defaults to ``results``). A row's key is its ``dataset``, ``estimator`` and
(Monte Carlo tables) ``statistic`` joined by ``/``; ``rows=`` keeps the rows whose key matches any of its
comma-separated shell patterns, ``columns=`` keeps those columns (the key columns always stay). A value is one cell:
``ROWS COLUMN`` with ``ROWS`` matching exactly one row (the text as the table prints it, ``mean ± std``), or with the
word ``mean`` the mean alone, or with ``range`` the smallest to the largest mean over every matching row (``a–b``).

Each table is introduced by the command that regenerates it and by its run's manifest: git revision, date,
machine, duration, cells and failures. A run whose configuration differs from the shipped one of its name (e.g. run
with ``--seeds 3`` for a quick look) is not quoted: it counts as missing, unless ``--reduced`` is given, and then its
tables say so in that line (marked †, with what differs) and its values carry a †. A source that is missing leaves
the page's current text in place and is reported; ``--strict`` makes that an error. A marker written as inline code
(after a backtick, as a page documenting the syntax writes it) is text, not a marker.

Without a page, every page a reader opens is done: the README and each ``research/**/*.md`` holding a marker
(:func:`reader_pages`). ``--check`` changes nothing and compares marker by marker (:func:`changes`): a table whose only
difference is its provenance line is the same numbers from another run (reported, exit 0), as is one whose only other
difference is which cells are marked best (bold: a tie rule changed); a changed cell or value is a changed number
(each listed with its old and new text, exit 1).

Either way, the claims of every shipped config that states some (:mod:`slamarena.experiments.claims`) are checked on
its run under ROOT: a claim that does not hold is listed with its value and bound, and the exit code is 1.
"""

from __future__ import annotations

import fnmatch
import re
from dataclasses import dataclass, field
from pathlib import Path

from slamarena.errors import UserError

from .results import MANIFEST, SUMMARY, atomic_write_text, read_json

__all__ = [
    "QuoteError",
    "Table",
    "Change",
    "read_table",
    "markers",
    "update_page",
    "changes",
    "reader_pages",
    "quote_main",
]

KEY_COLUMNS = ("dataset", "estimator", "statistic")
REDUCED = "†"  # marks what comes from a run that is not the shipped config's (quoted only with reduced=True)
_TABLE = re.compile(r"(?<!`)(<!-- table: (?P<spec>[^>]*?) -->\n)(?P<body>(?:(?!<!--).)*?)(<!-- /table -->)", re.S)
_VALUE = re.compile(r"(?<!`)(<!-- value: (?P<spec>[^>]*?) -->)(?P<body>(?:(?!<!--).)*?)(<!-- /value -->)", re.S)
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)(e[-+]?\d+)?$", re.I)


class QuoteError(UserError, ValueError):
    """A marker that cannot be resolved: a malformed spec, an unknown column, a row pattern that matches nothing."""


class MissingSource(QuoteError):
    """The results a marker quotes are not there (the experiment has not been run into this results root)."""


@dataclass
class Table:
    """A results table as written in Markdown: header, rows of cell texts (as written: the best marked bold), legend lines."""

    header: list[str]
    rows: list[list[str]]
    legend: list[str] = field(default_factory=list)

    def key(self, row: list[str]) -> str:
        return "/".join(row[k] for k, c in enumerate(self.header) if c in KEY_COLUMNS)

    def column(self, name: str) -> int:
        if name not in self.header:
            raise QuoteError(f"no column {name!r}; the table has {', '.join(self.header)}")
        return self.header.index(name)

    def matching(self, patterns: str) -> list[list[str]]:
        return [r for r in self.rows if any(fnmatch.fnmatchcase(self.key(r), p) for p in patterns.split(","))]


def read_table(path: Path) -> Table:
    """Parse a table Markdown file of :mod:`slamarena.experiments.tables` (a pipe table, then its legend)."""
    lines = Path(path).read_text().splitlines()
    table = [ln for ln in lines if ln.startswith("|")]
    if len(table) < 2:
        raise QuoteError(f"{path}: no Markdown table in it")
    cells = [[c.strip() for c in ln.strip().strip("|").split("|")] for ln in table]
    legend = [ln for ln in lines[lines.index(table[-1]) + 1 :] if ln.strip()]
    return Table(cells[0], cells[2:], legend)


def _parse_spec(spec: str, positional: int) -> tuple[list[str], dict[str, str]]:
    words = spec.split()
    args, options = [w for w in words if "=" not in w], dict(w.split("=", 1) for w in words if "=" in w)
    if len(args) != positional and not (positional == 3 and len(args) == 4):
        raise QuoteError(
            f"marker {spec!r}: expected {'SOURCE [rows=…] [columns=…]' if positional == 1 else 'SOURCE ROWS COLUMN [mean|range]'}"
        )
    unknown = set(options) - {"rows", "columns"}
    if unknown:
        raise QuoteError(f"marker {spec!r}: unknown option(s) {', '.join(sorted(unknown))} (rows=, columns=)")
    return args, options


def _source(root: Path, source: str, reduced: bool = False) -> tuple[Path, Path]:
    """(the experiment's results directory, its table file) for ``EXPERIMENT/TABLE``; a run that is not the shipped
    config's is missing unless ``reduced``."""
    if source.count("/") != 1:
        raise QuoteError(f"source {source!r} is not EXPERIMENT/TABLE")
    experiment, table = source.split("/")
    path = root / experiment / "tables" / f"{table}.md"
    if not path.is_file():
        raise MissingSource(
            f"{path} does not exist: run `slamarena run {experiment}` (results into {root / experiment})"
        )
    if not reduced and (differs := not_shipped(root / experiment)):
        raise MissingSource(
            f"{root / experiment} is not a run of the shipped config ({'; '.join(differs[:3])}): run `slamarena run {experiment}`, "
            f"or quote it with --reduced"
        )
    return root / experiment, path


def _differences(shipped: dict, ran: dict, prefix: str = "") -> list[str]:
    """The settings where the run's config differs from the shipped one, as ``path: ran (shipped: …)``."""
    if isinstance(shipped, dict) and isinstance(ran, dict):
        return [
            d
            for k in sorted(set(shipped) | set(ran))
            for d in _differences(shipped.get(k), ran.get(k), f"{prefix}{k}.")
        ]
    if isinstance(shipped, list) and isinstance(ran, list) and shipped != ran:
        if len(shipped) != len(ran):
            labels = [e.get("label") or e.get("name") if isinstance(e, dict) else e for e in ran]
            return [f"{prefix.rstrip('.')}: {len(ran)} of {len(shipped)} ({', '.join(map(str, labels))})"]
        return [d for k, (a, b) in enumerate(zip(shipped, ran)) for d in _differences(a, b, f"{prefix}{k}.")]
    if shipped != ran:
        return [f"{prefix.rstrip('.')}: {ran!r} (shipped: {shipped!r})"]
    return []


def not_shipped(run_dir: Path) -> list[str]:
    """How the config a run was made with differs from the shipped config of its name (empty: it is the shipped one)."""
    from .config import ConfigError, load_config

    if not (run_dir / MANIFEST).is_file():
        return ["no manifest.json"]
    manifest = read_json(run_dir / MANIFEST)
    try:
        shipped = load_config(manifest.get("experiment", run_dir.name)).model_dump(mode="json")
    except ConfigError:
        return ["no shipped config of this name"]
    from .config import sanitize

    ran = dict(manifest.get("config", {}))
    for key in ("output", "claims"):  # where the results go and what is claimed of them do not change a number
        ran.pop(key, None)
        shipped.pop(key, None)
    kept = {d.get("label") or sanitize(d["name"]) for d in ran.get("datasets", [])}
    for row in shipped.get(
        "published", []
    ):  # a dataset left out takes its published values with it: not a difference of its own
        row["values"] = {d: v for d, v in row["values"].items() if d in kept}
    return _differences(shipped, ran)


def provenance(run_dir: Path) -> str:
    """One line: the command, and the manifest's revision, date, machine, duration, cells; a non-shipped config flagged."""
    name = run_dir.name
    if not (run_dir / MANIFEST).is_file():
        return f"`slamarena run {name}` (no manifest.json beside the table)"
    manifest = read_json(run_dir / MANIFEST)
    machine = manifest.get("machine", {})
    cells = manifest.get("cells", {})
    revision = str(manifest.get("git_revision") or "unknown")
    parts = [
        f"git {revision[:12]}" + (" with uncommitted changes" if revision.endswith("-dirty") else ""),
        str(manifest.get("finished") or manifest.get("started") or "")[:10],
        f"{machine.get('hostname', '?')} ({machine.get('cpus', '?')} CPUs)",
    ]
    if manifest.get("duration_s") is not None:
        parts.append(f"{manifest['duration_s'] / 60:.1f} min with `-j {manifest.get('jobs', 1)}`")
    if cells:
        cached = f" ({cells['cached']} taken from the cache of an earlier run)" if cells.get("cached") else ""
        parts.append(f"{cells.get('total', '?')} cells{cached}, {len(manifest.get('failed', []))} failed")
    line = f"`slamarena run {manifest.get('experiment', name)}`: " + ", ".join(p for p in parts if p)
    differs = not_shipped(run_dir)
    if differs:
        line += (
            f". **{REDUCED} Not the shipped config** — "
            + "; ".join(differs[:4])
            + (f"; … {len(differs) - 4} more" if len(differs) > 4 else "")
        )
    return line + "."


def failures(run_dir: Path, table: Table) -> list[str]:
    """The failed cells of the rows shown (dataset/estimator in the table), with the first line of their error."""
    import csv

    path = run_dir / SUMMARY
    if not path.is_file():
        return []
    shown = (
        {(r[table.header.index("dataset")], r[table.header.index("estimator")]) for r in table.rows}
        if "estimator" in table.header
        else None
    )
    out = []
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            if row.get("status", "ok") != "ok" and (shown is None or (row["dataset"], row["estimator"]) in shown):
                error = (row.get("error") or "").splitlines()[0][:200] if row.get("error") else ""
                out.append(f"- failed: {row['dataset']}/{row['estimator']}/{row['seed']} ({row['status']}): {error}")
    return out


def render_table(root: Path, spec: str, reduced: bool = False) -> str:
    (source,), options = _parse_spec(spec, 1)
    run_dir, path = _source(root, source, reduced)
    table = read_table(path)
    rows = table.matching(options["rows"]) if "rows" in options else table.rows
    if not rows:
        raise QuoteError(
            f"{spec!r}: rows={options['rows']} matches no row of {path} (keys: {', '.join(table.key(r) for r in table.rows)})"
        )
    keep = list(range(len(table.header)))
    if "columns" in options:
        wanted = options["columns"].split(",")
        keep = [k for k, c in enumerate(table.header) if c in KEY_COLUMNS or c == "n"] + [
            table.column(c) for c in wanted
        ]
    shown = Table([table.header[k] for k in keep], [[r[k] for k in keep] for r in rows])
    numeric = [k for k, c in enumerate(shown.header) if c not in KEY_COLUMNS]
    lines = [
        "| " + " | ".join(shown.header) + " |",
        "|" + "|".join("---:" if k in numeric else "---" for k in range(len(shown.header))) + "|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in shown.rows]
    columns = set(shown.header)
    legend = [
        ln
        for ln in table.legend
        if not (m := re.match(r"- `?([^`:]+)`?:", ln)) or m.group(1) in columns or "(published)" in ln
    ]
    return "\n".join([provenance(run_dir), "", *lines, "", *legend, *failures(run_dir, shown)]) + "\n"


def _plain(text: str) -> str:
    """A cell's text without its best-value mark."""
    return text.replace("**", "")


def _mean(text: str) -> float | None:
    head = _plain(text).split(" ± ")[0].strip()
    return float(head) if _NUMBER.match(head) else None


def render_value(root: Path, spec: str, reduced: bool = False) -> str:
    """The cell (or mean, or range) a value marker names; marked † when it comes from a run that is not the shipped config's."""
    text = _value(root, spec, reduced)
    run_dir = root / spec.split()[0].split("/")[0]
    return text + REDUCED if reduced and not_shipped(run_dir) else text


def _value(root: Path, spec: str, reduced: bool) -> str:
    args, _ = _parse_spec(spec, 3)
    source, pattern, column = args[:3]
    mode = args[3] if len(args) == 4 else "text"
    if mode not in ("text", "mean", "range"):
        raise QuoteError(f"value {spec!r}: the fourth word is 'mean' or 'range', not {mode!r}")
    _, path = _source(root, source, reduced)
    table = read_table(path)
    k = table.column(column)
    rows = table.matching(pattern)
    if not rows:
        raise QuoteError(
            f"value {spec!r}: {pattern} matches no row of {path} (keys: {', '.join(table.key(r) for r in table.rows)})"
        )
    if mode == "range":
        means = [(m, _plain(r[k]).split(" ± ")[0]) for r in rows if (m := _mean(r[k])) is not None]
        if not means:
            raise QuoteError(f"value {spec!r}: no number in column {column} of the matching rows")
        lo, hi = min(means)[1], max(means)[1]
        return lo if lo == hi else f"{lo}–{hi}"
    if len(rows) != 1:
        raise QuoteError(
            f"value {spec!r}: {pattern} matches {len(rows)} rows ({', '.join(table.key(r) for r in rows)}); "
            "use 'range' or a narrower pattern"
        )
    return _plain(rows[0][k]).split(" ± ")[0] if mode == "mean" else _plain(rows[0][k])


def markers(text: str) -> list[tuple[str, str]]:
    """The page's markers in order of kind: ``("table", spec)`` …, then ``("value", spec)`` …."""
    return [("table", m.group("spec").strip()) for m in _TABLE.finditer(text)] + [
        ("value", m.group("spec").strip()) for m in _VALUE.finditer(text)
    ]


def update_page(text: str, root: Path, strict: bool = False, reduced: bool = False) -> tuple[str, list[str]]:
    """The page with every marker's content regenerated from ``root``; and the missing sources (kept as they were).
    ``reduced``: quote runs of a config other than the shipped one too (flagged †), else they count as missing."""
    missing: list[str] = []

    def replace(render, match):
        try:
            body = render(root, match.group("spec").strip(), reduced)
        except MissingSource as exc:
            if strict:
                raise
            missing.append(str(exc))
            return match.group(0)
        return match.group(1) + body + match.group(4)

    text = _TABLE.sub(lambda m: replace(render_table, m), text)
    text = _VALUE.sub(lambda m: replace(render_value, m), text)
    return text, sorted(set(missing))


@dataclass(frozen=True)
class Change:
    """One marker whose regenerated content differs from the page's: ``numbers`` (a cell or a value changed),
    ``provenance`` (a table whose numbers are the same, from another run: only its first line differs) or ``marks``
    (the same numbers, only the bold marks of the best cells differ, with or without a new provenance line)."""

    kind: str  # "table" | "value"
    spec: str
    what: str  # "numbers" | "provenance" | "marks"
    old: str
    new: str


def _bodies(text: str) -> list[tuple[str, str, str]]:
    """(kind, spec, body) of every marker in page order (tables, then values, as :func:`markers`)."""
    return [("table", m.group("spec").strip(), m.group("body")) for m in _TABLE.finditer(text)] + [
        ("value", m.group("spec").strip(), m.group("body")) for m in _VALUE.finditer(text)
    ]


def _provenance_and_rest(body: str) -> tuple[str, str]:
    head, _, rest = body.partition("\n")
    return (head, rest) if head.startswith("`slamarena run ") else ("", body)


def changes(old: str, new: str) -> list[Change]:
    """The markers whose content differs between a page and its regenerated text (same prose, same markers)."""
    before, after = _bodies(old), _bodies(new)
    if [b[:2] for b in before] != [a[:2] for a in after]:
        raise QuoteError("the two texts do not hold the same markers")
    out = []
    for (kind, spec, a), (_, _, b) in zip(before, after):
        if a == b:
            continue
        if kind == "table":
            (pa, ra), (pb, rb) = _provenance_and_rest(a), _provenance_and_rest(b)
            if ra == rb and pa != pb:
                out.append(Change(kind, spec, "provenance", pa, pb))
                continue
            if ra.replace("**", "") == rb.replace("**", ""):
                out.append(Change(kind, spec, "marks", a, b))
                continue
        out.append(Change(kind, spec, "numbers", a, b))
    return out


def reader_pages(repo: Path) -> list[Path]:
    """The pages a reader opens that quote results: ``README.md`` and every ``research/**/*.md`` holding a marker."""
    pages = [repo / "README.md"] if (repo / "README.md").is_file() else []
    for path in sorted((repo / "research").rglob("*.md")):
        text = path.read_text()
        if _TABLE.search(text) or _VALUE.search(text):
            pages.append(path)
    return pages


def _check(page: Path, old: str, new: str) -> bool:
    """Print what regenerating ``page`` would change; True if a number would."""
    found = changes(old, new)
    numbers = [c for c in found if c.what == "numbers"]
    moved = [c for c in found if c.what == "provenance"]
    marked = [c for c in found if c.what == "marks"]
    if not found:
        print(f"{page}: up to date")
    if moved:
        print(
            f"{page}: {len(moved)} table(s) with the same numbers from another run (only the provenance line differs):"
        )
        for c in moved:
            print(f"  {c.spec}: {c.old} → {c.new}")
    if marked:
        print(f"{page}: {len(marked)} table(s) with the same numbers, other best cells marked (bold):")
        for c in marked:
            print(f"  {c.spec}")
    if numbers:
        print(f"{page}: {len(numbers)} quoted number(s) changed:")
        for c in numbers:
            if c.kind == "value":
                print(f"  value {c.spec}: {c.old!r} → {c.new!r}")
            else:
                gone = [ln for ln in c.old.splitlines() if ln not in c.new.splitlines()]
                came = [ln for ln in c.new.splitlines() if ln not in c.old.splitlines()]
                print(f"  table {c.spec}:")
                print("\n".join([*(f"    - {ln}" for ln in gone), *(f"    + {ln}" for ln in came)]))
    return bool(numbers)


def quote_main(
    page: Path | list[Path] | None,
    root: Path,
    strict: bool = False,
    check: bool = False,
    reduced: bool = False,
    repo: Path = Path("."),
) -> int:
    """``slamarena results``: rewrite the pages in place (none given: :func:`reader_pages` of ``repo``). ``check``: change
    nothing, say per page whether it is up to date, whose tables only have a new provenance line, and which numbers
    changed; exit 1 if a number changed."""
    pages = reader_pages(Path(repo)) if page is None else [page] if isinstance(page, (str, Path)) else list(page)
    if not pages:
        raise QuoteError(f"no page with markers under {Path(repo).resolve()} (README.md, research/)")
    status = 0
    for page in map(Path, pages):
        if not page.is_file():
            raise QuoteError(f"{page}: no such page")
        old = page.read_text()
        new, missing = update_page(old, Path(root), strict, reduced)
        for m in missing:
            print(f"kept as it was (no results): {m}")
        if check:
            status |= int(_check(page, old, new))
            continue
        if new != old:
            atomic_write_text(page, new)
        counts = f"{len(_TABLE.findall(new))} tables, {len(_VALUE.findall(new))} values; {len(missing)} sources missing"
        print(f"{page}: {'regenerated' if new != old else 'unchanged'} from {root} ({counts})")
    from .claims import check_shipped

    return status | check_shipped(Path(root))
