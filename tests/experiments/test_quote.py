"""`slamarena results`: a page's quoted tables and values regenerated from the runs, prose left alone; and the page
the project ships (research/results.md) quotes only tables the shipped configs write."""

from __future__ import annotations

from pathlib import Path

import pytest

from slamarena.experiments.config import load_config, shipped_configs
from slamarena.experiments.quote import (
    MissingSource,
    QuoteError,
    changes,
    markers,
    quote_main,
    read_table,
    reader_pages,
    render_value,
    update_page,
)
from slamarena.experiments.results import write_json

ROOT = Path(__file__).resolve().parents[2]

ACCURACY = """| dataset | estimator | n | ate.rmse | map.rmse |
|---|---|---:|---:|---:|
| world | dead_reckoning | 3 | 1.11 ± 0.36 | – |
| world | ekf_slam | 3 | **0.054 ± 0.013** | 0.056 ± 0.019 |
| world | paper (published) | – | 0.2 | – |
| other | ekf_slam | 3 | 0.09 ± 0.01 | 0.1 ± 0.02 |

n: seeds; mean ± std over seeds; best per dataset in bold.

- `ate.rmse`: ATE RMSE [m]
- `map.rmse`: landmark RMSE [m]
- paper (published): A. Author, 2009
"""


def _run(root: Path, name: str = "plaza", config: dict | None = None, failed: bool = False) -> Path:
    """A results directory of the shipped config ``name`` (or of ``config``) holding the table above."""
    run = root / name
    (run / "tables").mkdir(parents=True)
    (run / "tables" / "accuracy.md").write_text(ACCURACY)
    write_json(
        run / "manifest.json",
        {
            "experiment": name,
            "config": config or load_config(name).model_dump(mode="json"),
            "git_revision": "0123456789abcdef",
            "finished": "2025-01-02T03:04:05",
            "machine": {"hostname": "box", "cpus": 2},
            "duration_s": 90.0,
            "jobs": 2,
            "cells": {"total": 7},
            "failed": ["other/ekf_slam/2"] if failed else [],
        },
    )
    status = "timeout" if failed else "ok"
    (run / "summary.csv").write_text(
        f"dataset,estimator,seed,status,error\nworld,ekf_slam,0,ok,\nother,ekf_slam,2,{status},{'timed out after 5 s' if failed else ''}\n"
    )
    return run


def test_a_table_marker_is_replaced_by_the_runs_table_with_its_command_provenance_and_legend(tmp_path):
    _run(tmp_path, failed=True)
    page = (
        "# Page\n\nProse stays.\n\n<!-- table: plaza/accuracy rows=world/* columns=ate.rmse -->\nold text\n"
        "<!-- /table -->\n\nMore prose.\n"
    )
    new, missing = update_page(page, tmp_path)
    assert not missing
    assert new.startswith(
        "# Page\n\nProse stays.\n\n<!-- table: plaza/accuracy rows=world/* columns=ate.rmse -->\n"
        "`slamarena run plaza`: git 0123456789ab, 2025-01-02, box (2 CPUs)"
    )
    assert "old text" not in new and new.endswith("<!-- /table -->\n\nMore prose.\n")
    assert (
        "| dataset | estimator | n | ate.rmse |\n|---|---|---:|---:|\n| world | dead_reckoning | 3 | 1.11 ± 0.36 |\n"
        "| world | ekf_slam | 3 | **0.054 ± 0.013** |" in new
    )  # the best mark kept
    assert (
        "| other |" not in new and "map.rmse" not in new
    )  # rows and columns filtered, the legend of a dropped column too
    assert "- `ate.rmse`: ATE RMSE [m]" in new and "- paper (published): A. Author, 2009" in new
    assert "failed: other/ekf_slam/2" not in new  # a failure of a row not shown is not listed
    everything, _ = update_page("<!-- table: plaza/accuracy -->\n<!-- /table -->\n", tmp_path)
    assert "- failed: other/ekf_slam/2 (timeout): timed out after 5 s" in everything
    assert update_page(new, tmp_path)[0] == new  # idempotent


def test_values_quote_one_cell_its_mean_or_a_range(tmp_path):
    _run(tmp_path)
    assert render_value(tmp_path, "plaza/accuracy world/ekf_slam ate.rmse") == "0.054 ± 0.013"
    assert render_value(tmp_path, "plaza/accuracy world/ekf_slam ate.rmse mean") == "0.054"
    assert render_value(tmp_path, "plaza/accuracy */ekf_slam ate.rmse range") == "0.054–0.09"
    page = "EKF <!-- value: plaza/accuracy world/ekf_slam map.rmse mean -->?<!-- /value --> m."
    assert (
        update_page(page, tmp_path)[0]
        == "EKF <!-- value: plaza/accuracy world/ekf_slam map.rmse mean -->0.056<!-- /value --> m."
    )
    with pytest.raises(QuoteError, match="matches 2 rows"):
        render_value(tmp_path, "plaza/accuracy */ekf_slam ate.rmse")
    with pytest.raises(QuoteError, match="no column 'ate.max'"):
        render_value(tmp_path, "plaza/accuracy world/ekf_slam ate.max")
    with pytest.raises(QuoteError, match="matches no row"):
        render_value(tmp_path, "plaza/accuracy nowhere/* ate.rmse")
    with pytest.raises(QuoteError, match="unknown option"):
        update_page("<!-- table: plaza/accuracy row=x -->\n<!-- /table -->", tmp_path)


def test_a_missing_run_keeps_the_text_and_is_reported_or_refused(tmp_path):
    page = "<!-- table: absent/accuracy -->\nkept\n<!-- /table -->\n"
    new, missing = update_page(page, tmp_path)
    assert new == page and len(missing) == 1 and "slamarena run absent" in missing[0]
    with pytest.raises(MissingSource):
        update_page(page, tmp_path, strict=True)
    documented = (
        "Write `<!-- value: EXPERIMENT/TABLE ROW COLUMN -->…<!-- /value -->` or `<!-- table: X/Y -->\n<!-- /table -->`."
    )
    assert markers(documented) == [] and update_page(documented, tmp_path, strict=True) == (documented, [])


def test_a_run_of_a_config_that_is_not_the_shipped_one_is_quoted_only_when_asked_and_flagged(tmp_path):
    shipped = load_config("plaza").model_dump(mode="json")
    _run(tmp_path, "plaza", config={**shipped, "seeds": 3})
    page = (
        "<!-- table: plaza/accuracy -->\nkept\n<!-- /table -->\n"
        "ATE <!-- value: plaza/accuracy world/ekf_slam ate.rmse mean -->?<!-- /value -->\n"
    )
    new, missing = update_page(page, tmp_path)
    assert new == page and "not a run of the shipped config (seeds: 3 (shipped: 1))" in missing[0]
    new, missing = update_page(page, tmp_path, reduced=True)
    assert not missing and "**† Not the shipped config** — seeds: 3 (shipped: 1)" in new and "-->0.054†<!--" in new
    _run(tmp_path / "same", "plaza", config=shipped)
    assert (
        "Not the shipped" not in update_page("<!-- table: plaza/accuracy -->\n<!-- /table -->\n", tmp_path / "same")[0]
    )


def test_read_table_keeps_the_cells_and_the_legend(tmp_path):
    (tmp_path / "t.md").write_text(ACCURACY)
    table = read_table(tmp_path / "t.md")
    assert table.header[:3] == ["dataset", "estimator", "n"] and table.rows[1][3] == "**0.054 ± 0.013**"
    assert [table.key(r) for r in table.matching("world/*")] == [
        "world/dead_reckoning",
        "world/ekf_slam",
        "world/paper (published)",
    ]
    assert table.legend[0].startswith("n: seeds")


def test_check_tells_a_new_provenance_line_from_a_changed_number(tmp_path, capsys):
    """`slamarena results --check`: the same numbers from another run (only the table's provenance line differs) is
    reported and passes; a changed cell or value is listed, old and new, and fails."""
    run = _run(tmp_path / "results")
    page = tmp_path / "page.md"
    source = (
        "<!-- table: plaza/accuracy rows=world/* columns=ate.rmse -->\n<!-- /table -->\n"
        "EKF <!-- value: plaza/accuracy world/ekf_slam ate.rmse mean -->?<!-- /value --> m\n"
    )
    page.write_text(update_page(source, tmp_path / "results")[0])
    assert quote_main(page, tmp_path / "results", check=True) == 0
    assert "page.md: up to date" in capsys.readouterr().out

    manifest = (run / "manifest.json").read_text()
    (run / "manifest.json").write_text(manifest.replace("0123456789abcdef", "fedcba9876543210"))
    assert quote_main(page, tmp_path / "results", check=True) == 0  # same numbers, new run
    out = capsys.readouterr().out
    assert "1 table(s) with the same numbers from another run" in out and "git fedcba987654" in out
    assert "changed" not in out
    old, new = page.read_text(), update_page(page.read_text(), tmp_path / "results")[0]
    assert [(c.kind, c.what) for c in changes(old, new)] == [("table", "provenance")]

    accuracy = (run / "tables" / "accuracy.md").read_text()
    (run / "tables" / "accuracy.md").write_text(accuracy.replace("**0.054 ± 0.013**", "0.054 ± 0.013"))
    assert quote_main(page, tmp_path / "results", check=True) == 0  # the same numbers, another cell marked best
    out = capsys.readouterr().out
    assert "1 table(s) with the same numbers, other best cells marked (bold)" in out and "changed" not in out

    (run / "tables" / "accuracy.md").write_text(ACCURACY.replace("0.054 ± 0.013", "0.061 ± 0.013"))
    assert quote_main(page, tmp_path / "results", check=True) == 1
    out = capsys.readouterr().out
    assert (
        "2 quoted number(s) changed" in out
        and "value plaza/accuracy world/ekf_slam ate.rmse mean: '0.054' → '0.061'" in out
    )
    assert (
        "    - | world | ekf_slam | 3 | **0.054 ± 0.013** |" in out
        and "    + | world | ekf_slam | 3 | **0.061 ± 0.013** |" in out
    )
    new = update_page(page.read_text(), tmp_path / "results")[0]
    assert {(c.kind, c.what) for c in changes(page.read_text(), new)} == {("table", "numbers"), ("value", "numbers")}
    assert page.read_text() == old  # --check writes nothing


def test_without_a_page_every_page_a_reader_opens_is_done(tmp_path, capsys):
    """No page given: README.md and every research page holding a marker, at any depth; pages without markers are left
    out; a number changed on any of them fails the check."""
    _run(tmp_path / "results")
    marker = "<!-- value: plaza/accuracy world/ekf_slam ate.rmse mean -->0.054<!-- /value -->\n"
    (tmp_path / "research" / "method").mkdir(parents=True)
    (tmp_path / "README.md").write_text("ATE " + marker)
    (tmp_path / "research" / "results.md").write_text(marker)
    (tmp_path / "research" / "method" / "ekf.md").write_text(marker.replace("0.054", "0.05"))
    (tmp_path / "research" / "prose.md").write_text("no markers\n")
    assert reader_pages(tmp_path) == [
        tmp_path / "README.md",
        tmp_path / "research" / "method" / "ekf.md",
        tmp_path / "research" / "results.md",
    ]
    assert quote_main(None, tmp_path / "results", check=True, repo=tmp_path) == 1
    out = capsys.readouterr().out
    assert "README.md: up to date" in out and "ekf.md: 1 quoted number(s) changed" in out
    assert quote_main(None, tmp_path / "results", repo=tmp_path) == 0
    assert "0.054<!--" in (tmp_path / "research" / "method" / "ekf.md").read_text()
    assert quote_main(None, tmp_path / "results", check=True, repo=tmp_path) == 0


def test_the_shipped_reader_pages_are_every_page_with_a_marker():
    """The pages `slamarena results` regenerates by default: the README, the results page, and each research page
    that quotes a number (the method pages and the discussion quote the five configs they discuss)."""
    pages = {p.relative_to(ROOT).as_posix() for p in reader_pages(ROOT)}
    assert {"README.md", "research/results.md", "research/README.md"} <= pages
    assert len(pages) >= 6, pages


@pytest.mark.parametrize("page", [p.relative_to(ROOT).as_posix() for p in reader_pages(ROOT)])
def test_the_pages_quote_only_tables_of_shipped_configs(page):
    """Every marker of every page a reader opens names a shipped config and a table (the Monte Carlo table, or the
    protocol's held-out table) it writes, and every column it asks for is one of that table's."""
    text = (ROOT / page).read_text()
    found = markers(text)
    assert found and len(found) == text.count("<!-- table: ") + text.count("<!-- value: ")
    configs = shipped_configs()
    for kind, spec in found:
        words = spec.split()
        experiment, table = words[0].split("/")
        assert experiment in configs, spec
        config = load_config(experiment)
        written = {t.name: t.columns for t in config.tables}
        if config.protocol is not None:  # the leave-one-log-out protocol writes tables/heldout.*
            from slamarena.experiments.protocol import HELDOUT_COLUMNS

            written["heldout"] = list(HELDOUT_COLUMNS)
        if table == "monte_carlo":
            from slamarena.experiments.tables import MONTE_CARLO_COLUMNS

            columns = list(MONTE_CARLO_COLUMNS)
        else:
            assert table in written, f"{spec}: {experiment} writes {', '.join(written)}"
            columns = ["dataset", "estimator", "n", *written[table]]
        asked = [w.split("=", 1)[1].split(",") for w in words if w.startswith("columns=")]
        asked = asked[0] if asked else ([words[2]] if kind == "value" else [])
        assert set(asked) <= set(columns), spec


def test_every_shipped_config_lists_with_a_description(capsys):
    from typer.testing import CliRunner

    from slamarena.experiments.cli import app

    configs = shipped_configs()
    assert {
        "default",
        "consistency",
        "mrclam",
        "victoria_park",
        "plaza",
        "pose_graphs",
        "kummerle2009",
        "scaling",
    } <= set(configs)
    assert all(configs.values()), [k for k, v in configs.items() if not v]
    out = CliRunner().invoke(app, ["run", "--list"]).output
    lines = out.strip().splitlines()
    assert len(lines) == len(configs) and all(line.split()[0] in configs for line in lines)


def test_a_run_on_part_of_the_grid_says_which_part(tmp_path):
    shipped = load_config("consistency")
    _run(tmp_path, "consistency", config=shipped.reduced(datasets=["hard"], seeds=3).model_dump(mode="json"))
    line = update_page("<!-- table: consistency/accuracy -->\n<!-- /table -->\n", tmp_path, reduced=True)[
        0
    ].splitlines()[1]
    assert (
        "datasets: 1 of 2 (hard)" in line
        and "estimators: 4 of 5 (ekf_slam, ekf_slam_fej, ekf_slam_oc, ekf_slam_ideal)" in line
        and "seeds: 3 (shipped: 30)" in line
    )
