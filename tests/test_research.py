"""The research pages and the notebook's scripts: the method pages stay short; every relative link resolves; each
script of research/scripts/ imports (its imports resolve against today's code, so a renamed function or module fails
here), has a ``main`` and is named by the research page whose numbers it made; every script a page names exists."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPTS = sorted((ROOT / "research" / "scripts").glob("*.py"))
PAGES = {p: p.read_text() for p in (ROOT / "research").rglob("*.md")}


def test_there_are_scripts():
    assert len(SCRIPTS) >= 50


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_a_script_imports_and_is_named_by_its_page(script):
    spec = importlib.util.spec_from_file_location(f"research_script_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # the imports only: the work is in main(), run under __main__
    assert callable(getattr(module, "main", None)), f"{script.name} has no main()"
    named = [p for p, text in PAGES.items() if f"research/scripts/{script.name}" in text]
    assert named, f"no research page names research/scripts/{script.name}"


def test_every_script_a_page_names_exists():
    missing = sorted(
        {
            (p.relative_to(ROOT).as_posix(), m)
            for p, text in PAGES.items()
            for m in re.findall(r"research/scripts/(\w+\.py)", text)
        }
        - {(p.relative_to(ROOT).as_posix(), s.name) for p in PAGES for s in SCRIPTS}
    )
    assert not missing, missing


QUICK = [s for s in SCRIPTS if "\nQUICK = " in s.read_text()]


def test_the_scripts_that_take_their_sizes_as_arguments_have_a_quick_run():
    assert {s.stem for s in QUICK} >= {
        "ekf_slam_cost_benchmark_K",
        "ekf_slam_cost_benchmark_KR",
        "fastslam_consistency_1",
    }


@pytest.mark.slow
@pytest.mark.parametrize("script", QUICK, ids=lambda p: p.stem)
def test_a_quick_run_finishes(script):
    """``python SCRIPT --quick`` runs the script through at its smallest size (slow: a simulation each, minutes on a
    loaded machine); it catches what an import cannot, a private attribute or a changed signature the body uses."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(script), "--quick"], cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip(), "printed nothing"


def test_every_relative_link_of_a_research_page_and_the_readme_resolves():
    """After the restructure of research/ (issue 34) every ``[text](path)`` of the README and of a research page names
    a file that exists (anchors are not checked)."""
    pages = {**PAGES, ROOT / "README.md": (ROOT / "README.md").read_text()}
    broken = [
        (p.relative_to(ROOT).as_posix(), target)
        for p, text in pages.items()
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
        if "://" not in target and not (p.parent / target).exists()
    ]
    assert not broken, broken


def test_a_method_page_stays_short():
    """research/method/<topic>.md holds a method's model, equations and parameters in at most ~200 lines; what was
    measured goes to a dated notebook page (research/README.md)."""
    long = {
        p.name: n for p in (ROOT / "research" / "method").glob("*.md") if (n := len(p.read_text().splitlines())) > 220
    }
    assert not long, long
