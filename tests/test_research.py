"""The research pages and the notebook's scripts: the method pages stay short; every relative link resolves; each
script of research/scripts/ imports (its imports resolve against today's code, so a renamed function or module fails
here), has a ``main`` and is named by the research page whose numbers it made; every script a page names exists; no
page holds an inline script (a heredoc fed to Python, a ``python -c`` of several lines) instead of naming one."""

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
        "input_validation_fastslam_cpu",
        "stereo_accuracy",
    }


@pytest.mark.slow
@pytest.mark.parametrize("script", QUICK, ids=lambda p: p.stem)
def test_a_quick_run_finishes(script):
    """``python SCRIPT --quick`` runs the script through at its smallest size (slow: a simulation each, minutes on a
    loaded machine); it catches what an import cannot, a private attribute or a changed signature the body uses. A
    script that reads staged data skips when the data is absent."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(script), "--quick"], cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode and "DatasetNotFoundError:" in done.stderr:
        error = next(line for line in done.stderr.splitlines() if "DatasetNotFoundError:" in line)
        pytest.skip(f"{script.name} reads a dataset that is not staged: {error}")
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


#: A heredoc fed to Python: ``python … <<EOF`` (or ``<<<``) on one line, or ``<<EOF … | python``.
_HEREDOC = re.compile(r"python[\w.]*(?:\s[^\n]*)?<<|<<-?\s*['\"]?\w+['\"]?[^\n]*\|[^\n]*python")
_DASH_C = re.compile(r"python[\w.]*\s+(?:-\S+\s+)*-c\s+(['\"])")


def inline_scripts(text: str) -> list[tuple[int, str]]:
    """The inline scripts of a research page as (line, what): a heredoc fed to Python, or a ``python -c`` whose
    program runs over more than one line. A one-line ``python -c`` is a command, not a script, and stays; a program
    continued by a backslash, or one wrapped inside a Markdown code span (where a line break is a space), is one
    line."""
    found = [(text.count("\n", 0, m.start()) + 1, "a heredoc fed to python") for m in _HEREDOC.finditer(text)]
    for m in _DASH_C.finditer(text):
        quote, start = m.group(1), m.end()
        end = start
        while (end := text.find(quote, end)) != -1 and quote == '"' and text[end - 1] == "\\":
            end += 1
        program = text[start : end if end != -1 else len(text)].replace("\\\n", " ")
        line_start = text.rfind("\n", 0, m.start()) + 1
        if text[line_start : m.start()].count("`") % 2:  # inside a code span: Markdown wrapping, not a line break
            program = program.replace("\n", " ")
        if "\n" in program.strip():
            found.append((text.count("\n", 0, m.start()) + 1, "a python -c program of more than one line"))
    return sorted(found)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("```bash\n.venv/bin/python - 3 <<'EOF'\nprint(1)\nEOF\n```\n", [(2, "a heredoc fed to python")]),
        ("x\ncat <<EOF | python3 -\nprint(1)\nEOF\n", [(2, "a heredoc fed to python")]),
        ('```\npython -c "import a\nprint(a)"\n```\n', [(2, "a python -c program of more than one line")]),
        ("`python -c 'import a; print(a)'` and `python -c \"import a;\nprint(a)\"`\n", []),
        ('python -c "import a; \\\n  print(a)"\n', []),
        ("python research/scripts/x.py --quick\n", []),
    ],
)
def test_inline_scripts_are_found(text, expected):
    assert inline_scripts(text) == expected


def test_no_research_page_holds_an_inline_script():
    """A script on a research page goes to research/scripts/ (imported here, named by its page) and the page gives
    the command that runs it (issue 34): an inline script escapes the import check and goes stale unseen."""
    found = [
        f"{p.relative_to(ROOT).as_posix()}:{line}: {what}"
        for p, text in PAGES.items()
        for line, what in inline_scripts(text)
    ]
    assert not found, "inline scripts (move each to research/scripts/ and give its command):\n" + "\n".join(found)
