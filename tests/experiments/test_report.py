"""``slamarena report`` and ``slamarena run --report``: one self-contained HTML file and its Markdown twin, with the
run's facts, every table with its caption, every figure with its caption, the failed cells, published reference
rows beside ours, two results directories side by side; and the HTML rendered by a real (headless) Chromium."""

from __future__ import annotations

import base64
import html
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest

from slamarena.experiments.metrics import output_columns
from slamarena.experiments.report import Cell, Results, Table, _anchor, _monte_carlo_table, to_html, write_report
from slamarena.experiments.report import to_markdown as report_markdown
from slamarena.experiments.tables import MONTE_CARLO_COLUMNS, aggregate

ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-c", "from slamarena.experiments.cli import main; main()"]
CONFIG = """
name: tiny_report
description: >-
  Dead reckoning and EKF-SLAM on a small landmark world; a batch smoother from dead reckoning allowed one iteration
  fails (it has not converged).
seeds: 2
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
estimators:
  - name: dead_reckoning
  - name: ekf_slam
  - name: gtsam_batch
    params: {max_iterations: 1, initial: dead_reckoning}   # from iSAM2's estimate one iteration is enough
metrics: [ate, rpe, nees, cost]
tables:
  - name: accuracy
    columns: [ate.rmse, rpe.trans_rmse]
  - name: cost
    columns: [cost.step_median, cost.wall]
figures: [trajectories, errors, nees]
"""
TABLES = {"table-run", "table-versions", "table-accuracy", "table-cost", "table-monte_carlo", "table-failed"}


def _cli(*args):
    return subprocess.run(
        [*CLI, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "COLUMNS": "400"},
    )


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A small run through the command line with --report: (results directory, the command's result)."""
    tmp = tmp_path_factory.mktemp("report")
    config = tmp / "tiny.yaml"
    config.write_text(textwrap.dedent(CONFIG))
    result = _cli("run", config, "--out", tmp / "results", "-j", "2", "--report")
    assert result.returncode == 1, result.stderr[-3000:]  # gtsam_batch's cells failed, the others ran
    return tmp / "results", result


class Page(HTMLParser):
    """What a reader of the HTML finds: tables (id → rows of (text, classes)), images, scripts and external links."""

    def __init__(self, text: str):
        super().__init__()
        self.tables: dict[str, list[list[tuple[str, str]]]] = {}
        self.images: list[dict] = []
        self.external: list[str] = []
        self.tags: list[str] = []
        self._table = self._row = self._cell = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        for key in ("src", "href"):
            if a.get(key) and not a[key].startswith(("data:", "#")):
                self.external.append(a[key])
        if tag == "table":
            self._table = self.tables.setdefault(a.get("id", ""), [])
        elif tag == "tr" and self._table is not None:
            self._row = []
            self._table.append(self._row)
        elif tag in ("td", "th") and self._row is not None:
            self._cell = [a.get("class", ""), ""]
        elif tag == "img":
            self.images.append(a)

    def handle_data(self, data):
        if self._cell is not None:
            self._cell[1] += data

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self._row.append((self._cell[1], self._cell[0]))
            self._cell = None
        elif tag == "table":
            self._table = None


def _row(table, *first):
    return next(r for r in table if tuple(c[0] for c in r[: len(first)]) == first)


def test_run_with_report_writes_one_self_contained_file_with_every_figure(run):
    out, result = run
    assert "report:" in result.stderr and (out / "report.html").is_file() and (out / "report.md").is_file()
    text = (out / "report.html").read_text()
    page = Page(text)
    assert page.external == [] and "script" not in page.tags and "link" not in page.tags  # nothing fetched when opened
    pngs = sorted((out / "figures").glob("*.png"))
    assert {p.stem for p in pngs} == {"trajectories_sim_landmarks", "errors_sim_landmarks", "nees_sim_landmarks"}
    embedded = {img["alt"]: base64.b64decode(img["src"].removeprefix("data:image/png;base64,")) for img in page.images}
    assert embedded == {p.stem: p.read_bytes() for p in pngs}
    for p in pngs:  # every figure with its caption (the figure module's, written beside it)
        caption = p.with_suffix(".caption").read_text().strip()
        assert len(caption) > 40 and html.escape(caption, quote=True) in text


def test_every_table_with_a_caption_that_says_what_each_column_is(run):
    out, _ = run
    text = (out / "report.html").read_text()
    page = Page(text)
    assert set(page.tables) == TABLES
    described = output_columns()
    for name, columns in (("accuracy", ["ate.rmse", "rpe.trans_rmse"]), ("cost", ["cost.step_median", "cost.wall"])):
        table = page.tables[f"table-{name}"]
        assert [c[0] for c in table[0]] == ["dataset", "method", "n", *columns]
        assert [r[1][0] for r in table[1:]] == ["dead_reckoning", "ekf_slam"]  # the failed method has no row
        for c in columns:
            assert html.escape(f"{c}: {described[c][1]}") in text
    assert html.escape('metric ate with align="se2"') in text  # the settings it was computed with
    assert "mean ± standard deviation over the seeds" in text
    ours = pd.read_csv(out / "summary.csv").query("estimator == 'ekf_slam'")["ate.rmse"]
    assert _row(page.tables["table-accuracy"], "sim_landmarks", "ekf_slam")[3][0].startswith(f"{ours.mean():.3g} ± ")
    for c, what in MONTE_CARLO_COLUMNS.items():
        assert html.escape(f"{c}: {what}") in text


def test_run_facts_config_and_failed_cells(run):
    out, _ = run
    manifest = json.loads((out / "manifest.json").read_text())
    text = (out / "report.html").read_text()
    page = Page(text)
    facts = dict((r[0][0], r[1][0]) for r in page.tables["table-run"][1:])
    assert (
        facts["git revision"] == str(manifest["git_revision"]) and manifest["machine"]["hostname"] in facts["machine"]
    )
    assert facts["cells"] == "6 total, 6 run, 0 cached, 2 failed"
    assert ("numpy", manifest["versions"]["numpy"]) in [(r[0][0], r[1][0]) for r in page.tables["table-versions"]]
    assert (
        "Dead reckoning and EKF-SLAM on a small landmark world" in text and "n_landmarks: 8" in text
    )  # the config as run
    failed = page.tables["table-failed"][1:]
    errors = pd.read_csv(out / "summary.csv").query("status != 'ok'")
    assert [(r[1][0], r[2][0]) for r in failed] == [("gtsam_batch", "0"), ("gtsam_batch", "1")]
    assert all(r[4][0] == e for r, e in zip(failed, errors["error"])) and "max_iterations" in failed[0][4][0]
    md = (out / "report.md").read_text()
    assert errors["error"].iloc[0] in md


def test_markdown_twin_has_the_same_tables_and_links_the_figures(run):
    out, _ = run
    md = (out / "report.md").read_text()
    for name in ("accuracy", "cost", "monte_carlo"):
        assert f"### {name}\n" in md
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(links) == 3 and all((out / link).is_file() for link in links)
    assert "| dataset | method | n | ate.rmse | rpe.trans_rmse |" in md


def test_published_rows_appear_beside_ours_with_their_citation(run, tmp_path):
    out = tmp_path / "with_published"
    shutil.copytree(run[0], out)
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["config"]["published"] = [
        {
            "label": "Paper",
            "citation": "A. Author et al., A SLAM paper, 2009",
            "values": {"sim_landmarks": {"ate.rmse": 0.123}, "elsewhere": {"ate.rmse": 9.0}},
        }
    ]
    (out / "manifest.json").write_text(json.dumps(manifest))
    html_path, md_path = write_report(out)
    page = Page(html_path.read_text())
    rows = page.tables["table-accuracy"]
    assert [r[1][0] for r in rows[1:]] == ["dead_reckoning", "ekf_slam", "Paper (published)"]
    assert rows[-1][3] == ("0.123", "published") and rows[-1][4] == ("–", "published")
    assert "Paper (published)" not in [r[1][0] for r in page.tables["table-cost"]]  # it gives no cost column
    assert html.escape("Paper (published): A. Author et al., A SLAM paper, 2009") in html_path.read_text()
    assert "| sim_landmarks* | *Paper (published)* |" in md_path.read_text().replace(
        "*sim_landmarks*", "sim_landmarks*"
    )


def test_two_runs_side_by_side_with_the_differences_highlighted(run, tmp_path):
    a, b = run[0], tmp_path / "b"
    shutil.copytree(a, b)
    manifest = json.loads((b / "manifest.json").read_text())
    manifest["git_revision"] = "0123abc"
    (b / "manifest.json").write_text(json.dumps(manifest))
    summary = pd.read_csv(b / "summary.csv")
    summary.loc[summary["estimator"] == "ekf_slam", "ate.rmse"] *= 2  # B is worse in one column
    summary.loc[summary["estimator"] == "ekf_slam", "rpe.trans_rmse"] /= 2  # and better in another
    summary.to_csv(b / "summary.csv", index=False)
    html_path, md_path = write_report(a, b, tmp_path / "cmp")
    assert html_path == tmp_path / "cmp.html" and md_path.is_file()
    text = html_path.read_text()
    page = Page(text)
    facts = {r[0][0]: (r[1], r[2]) for r in page.tables["table-run"][1:]}
    assert facts["git revision"][1] == ("0123abc", "changed") and facts["machine"][1][1] == ""
    acc = page.tables["table-accuracy"]
    assert [c[0] for c in acc[0]][:6] == ["dataset", "method", "n A", "n B", "ate.rmse A", "ate.rmse B"]
    ekf, dr = _row(acc, "sim_landmarks", "ekf_slam"), _row(acc, "sim_landmarks", "dead_reckoning")
    assert ekf[5][1] == "changed worse" and ekf[7][1] == "better changed" and ekf[4][1] == ""
    assert all(c[1] == "" for c in dr)
    assert "A and B ran the same config" in text
    assert (
        len(page.images) == 6 and [i["alt"] for i in page.images[:2]] == ["trajectories_sim_landmarks"] * 2
    )  # figures in pairs
    manifest["config"]["seeds"] = 3
    (b / "manifest.json").write_text(json.dumps(manifest))
    text = write_report(a, b, tmp_path / "cmp2")[0].read_text()
    assert "The configs differ" in text and '<pre class="changed">' in text and "+seeds: 3" in text


def test_report_of_a_folder_that_is_not_a_results_directory_is_a_user_error(tmp_path):
    result = _cli("report", tmp_path)
    assert (
        result.returncode == 2
        and "not a results directory (no manifest.json" in result.stderr
        and "Traceback" not in result.stderr
    )
    (tmp_path / "manifest.json").write_text("{not json")
    result = _cli("report", tmp_path)
    assert result.returncode == 2 and f"{tmp_path / 'manifest.json'}: unreadable manifest" in result.stderr


# ---------------------------------------------------------------------------- in a real browser
CHROMIUM = next(
    (shutil.which(name) for name in ("chromium", "chromium-browser", "google-chrome") if shutil.which(name)), None
)
ARTIFACTS = Path(os.environ.get("SLAMARENA_TEST_ARTIFACTS", ROOT / "results" / "test-artifacts"))
#: added to a copy of the report: on load, writes what the browser made of every image and table into the page
CHECK = """<script>window.addEventListener("load", () => {
  const out = document.createElement("pre"); out.id = "report-check";
  out.textContent = JSON.stringify({images: [...document.images].map(i => [i.alt, i.complete, i.naturalWidth, i.naturalHeight]),
                                    tables: [...document.querySelectorAll("table")].map(t => [t.id, t.rows.length])});
  document.body.appendChild(out); });</script>"""


def _chromium(tmp_path, *args):
    flags = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        f"--user-data-dir={tmp_path / 'chromium-profile'}",
    ]
    result = subprocess.run([CHROMIUM, *flags, *args], capture_output=True, text=True, timeout=180)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout


def _rendered(tmp_path, page_text: str, name: str) -> dict:
    page = tmp_path / name
    page.write_text(page_text.replace("</body>", CHECK + "</body>"))
    dom = _chromium(tmp_path, "--virtual-time-budget=20000", "--dump-dom", page.as_uri())
    return json.loads(html.unescape(re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S).group(1)))


@pytest.mark.skipif(
    CHROMIUM is None, reason="Chromium is not installed (Debian: apt-get install chromium; .ci/run installs it)"
)
def test_report_renders_in_headless_chromium(run, tmp_path):
    out, _ = run
    text = (out / "report.html").read_text()
    seen = _rendered(tmp_path, text, "check.html")
    assert sorted(i[0] for i in seen["images"]) == sorted(p.stem for p in (out / "figures").glob("*.png"))
    assert all(complete and width > 0 and height > 0 for _, complete, width, height in seen["images"]), seen["images"]
    assert {t for t, _ in seen["tables"]} == TABLES and all(rows > 1 for _, rows in seen["tables"])
    # the check can fail: a figure whose bytes are not an image does not decode
    broken = re.sub(r"(data:image/png;base64,)[A-Za-z0-9+/]{200}", r"\g<1>" + "A" * 200, text, count=1)
    assert sorted(w for _, _, w, _ in _rendered(tmp_path, broken, "broken.html")["images"])[0] == 0
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shot = ARTIFACTS / "report_screenshot.png"
    shot.unlink(missing_ok=True)
    _chromium(
        tmp_path, "--window-size=1280,4000", "--hide-scrollbars", f"--screenshot={shot}", (out / "report.html").as_uri()
    )
    assert shot.read_bytes()[:4] == b"\x89PNG" and shot.stat().st_size > 50_000
    print(f"report screenshot kept at {shot}")


# ---------------------------------------------------------------------------- what a reader trusts
def test_every_mean_that_reads_as_the_best_is_marked():
    """0.05012 and 0.05014 both read 0.0501: both are the best a reader sees."""
    frame = pd.DataFrame(
        {
            "dataset": ["d"] * 6,
            "estimator": ["a", "a", "b", "b", "c", "c"],
            "seed": [0, 1] * 3,
            "status": ["ok"] * 6,
            "ate.rmse": [0.05011, 0.05013, 0.05013, 0.05015, 0.06, 0.06],
        }
    )
    _, _, best = aggregate(frame, ["ate.rmse"])
    assert best["ate.rmse"].tolist() == [True, True, False]


def _results_with(tmp_path, estimators, mc_rows) -> Results:
    (tmp_path / "tables").mkdir(parents=True, exist_ok=True)
    pd.DataFrame(mc_rows).to_csv(tmp_path / "tables" / "monte_carlo.csv", index=False)
    return Results(tmp_path, {"config": {"name": "t", "estimators": estimators}}, None)


def _mc_row(estimator, value, statistic="nees"):
    return dict(
        dataset="sim_landmarks",
        estimator=estimator,
        statistic=statistic,
        runs=5,
        stamps=100,
        mean_over_dof=value,
        in_band=0.1,
        early_over_dof=1.0,
        late_over_dof=value,
        band_lo_over_dof=0.6,
        band_hi_over_dof=1.5,
    )


def test_fastslam_over_confidence_is_named_and_linked_to_its_explanation(tmp_path):
    r = _results_with(
        tmp_path,
        [{"name": "fastslam", "params": {"version": 2}}, {"name": "ekf_slam", "label": "ekf_fej"}],
        [_mc_row("fastslam", 50.0), _mc_row("ekf_fej", 50.0), _mc_row("fastslam", 80.0, "nis")],
    )
    caption = _monte_carlo_table(r).caption
    notes = [i for i in caption.items if "NEES / dof" in i]
    assert len(notes) == 1  # FastSLAM's NEES only: the EKF's 50 has no recorded explanation, NIS is not NEES
    assert notes[0].startswith("fastslam on sim_landmarks: NEES / dof = 50 ") and "expected" in notes[0]
    assert "7.1× the standard deviation it reports" in notes[0]
    ((where, href),) = caption.links.items()
    assert where in notes[0] and where.startswith("research/notebook/2026-11-23-fastslam-consistency.md § ")
    page, anchor = href.split("#")
    headings = (ROOT / "research" / "notebook" / "2026-11-23-fastslam-consistency.md").read_text().splitlines()
    assert page == (ROOT / "research" / "notebook" / "2026-11-23-fastslam-consistency.md").as_uri()
    assert anchor in {_anchor(h.lstrip("#").strip()) for h in headings if h.startswith("#")}  # the link lands
    html_text = to_html("t", [Table("table-monte_carlo", ["a"], [[Cell("1")]], caption)])
    assert f'<a href="{href}">{html.escape(where)}</a>' in html_text
    assert f"[{where}]({href})" in report_markdown("t", [caption], tmp_path)
    consistent = _results_with(tmp_path, [{"name": "fastslam"}], [_mc_row("fastslam", 1.2)])
    assert not [i for i in _monte_carlo_table(consistent).caption.items if "NEES / dof" in i]


@pytest.mark.skipif(
    CHROMIUM is None, reason="Chromium is not installed (Debian: apt-get install chromium; .ci/run installs it)"
)
def test_a_wide_table_scrolls_inside_the_page_instead_of_being_clipped(tmp_path):
    columns = [f"metric_{k}.output_{k}" for k in range(30)]
    table = Table(
        "table-wide",
        ["dataset", "method", *columns],
        [[Cell("sim_landmarks"), Cell("ekf_slam")] + [Cell("0.0123 ± 0.0045")] * 30],
    )
    page = tmp_path / "wide.html"
    probe = """<script>window.addEventListener("load", () => {
      const t = document.getElementById("table-wide"), box = t.parentElement;
      const out = document.createElement("pre"); out.id = "report-check";
      out.textContent = JSON.stringify({page: document.documentElement.scrollWidth, window: window.innerWidth,
        box: box.clientWidth, box_scroll: box.scrollWidth, table: t.offsetWidth,
        overflow: getComputedStyle(box).overflowX});
      document.body.appendChild(out); });</script>"""
    page.write_text(to_html("wide", [table]).replace("</body>", probe + "</body>"))
    dom = _chromium(tmp_path, "--window-size=1400,900", "--virtual-time-budget=5000", "--dump-dom", page.as_uri())
    seen = json.loads(html.unescape(re.search(r'<pre id="report-check">(.*?)</pre>', dom, re.S).group(1)))
    assert seen["table"] > seen["window"]  # the table is wider than the window ...
    assert seen["page"] <= seen["window"]  # ... but the page is not: nothing is cut off at the window's edge
    assert seen["overflow"] == "auto" and seen["box_scroll"] >= seen["table"] > seen["box"]  # the table scrolls
