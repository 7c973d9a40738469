"""The notebook's scripts (research/scripts/): each imports (its imports resolve against today's code, so a renamed
function or module fails here), has a ``main``, and is named by the research page whose numbers it made; every script a
page names exists."""

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
