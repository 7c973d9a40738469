"""What ``slamarena bench`` prints (the benchmarks themselves are not part of the test suite): headers with
``[ms]`` survive rich, every stated aim carries a verdict, ``bench list`` describes each benchmark and its data."""

from __future__ import annotations

import ast
import importlib.util
import io
import re
from pathlib import Path

import pytest
from rich.console import Console

from slamarena.datasets.registry import resolve
from slamarena.experiments import benchmarks
from slamarena.experiments.benchmarks import ekf_slam

MODULES = sorted(
    Path(importlib.util.find_spec(target.partition(":")[0]).origin) for target in benchmarks.BENCHMARKS.values()
)


def rendered(renderable) -> str:
    console = Console(file=io.StringIO(), width=400)
    console.print(renderable)
    return console.file.getvalue()


def test_table_headers_and_title_keep_their_brackets():
    out = benchmarks.table("time [s] per step", ("n", "sequential [ms]", "trans. [m]", "rot. [rad]"))
    out.add_row("1", "2", "3", "4")
    text = rendered(out)
    for kept in ("time [s] per step", "sequential [ms]", "trans. [m]", "rot. [rad]"):
        assert kept in text


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.stem)
def test_every_benchmark_makes_its_tables_with_the_shared_helper(path):
    """A rich ``Table`` made directly reads its headers as markup (``[ms]`` disappears)."""
    tree = ast.parse(path.read_text())
    names = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert "Table" not in names


def test_aim_always_states_a_verdict():
    assert benchmarks.aim("≤ 2×", True) == "(aim ≤ 2×: met)"
    assert benchmarks.aim("≤ 2×", False) == "(aim ≤ 2×: not met)"
    assert benchmarks.aim("≤ 2×", None, "this run stops at n = 400") == (
        "(aim ≤ 2×: not measurable at this size, this run stops at n = 400)"
    )


def _strings_outside_docstrings(tree: ast.Module) -> list[str]:
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.FunctionDef | ast.ClassDef)
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    return [
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
    ]


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.stem)
def test_benchmarks_state_aims_only_through_the_verdict_helper(path):
    """An aim is printed only by ``aim()`` or beside ``verdict()``, which always say met / not met / not measurable."""
    stated = [s for s in _strings_outside_docstrings(ast.parse(path.read_text())) if re.search(r"\baim\b", s)]
    assert not stated, f"{path.name} states an aim without a verdict: {stated}"


def _rows(sizes):
    return [
        {"n": n, "N": 3 + 2 * n, "sequential": 1.5e-6 * n**2, "batch": 2e-6 * n**2, "per_observation": 3e-6 * n**2}
        | {"syrk20": 1e-6 * n**2, "one_pass": 1e-7 * n**2}
        | ({"reference": 1e-3 * n} if n <= 200 else {})
        for n in sizes
    ]


def test_ekf_slam_quick_says_its_sizes_cannot_judge_the_aims():
    exponents = dict.fromkeys(("sequential", "batch", "per_observation", "syrk20"), 2.0)
    lines = ekf_slam.summary(_rows([25, 50, 100, 200, 400]), exponents, (100, 400), 1.0, 200)
    aims = [line for line in lines if "aim" in line]
    assert len(aims) == 2
    assert all("not measurable at this size" in line for line in aims)


def test_ekf_slam_full_run_judges_the_aims():
    exponents = dict.fromkeys(("sequential", "batch", "per_observation", "syrk20"), 2.0)
    rows = _rows([25, 50, 100, 200, 400, 800, 1600, 3200])
    lines = ekf_slam.summary(rows, exponents, (800, 3200), 1.0, 800)
    aims = [line for line in lines if "aim" in line]
    assert len(aims) == 3  # the exponent, the syrk ratio at n = 1600 and at 3200
    assert all(": met" in line for line in aims)
    rows[-1]["sequential"] = 3 * rows[-1]["syrk20"]
    lines = ekf_slam.summary(rows, exponents | {"sequential": 2.5}, (800, 3200), 1.0, 800)
    assert [line.startswith("n = 3200") for line in lines if ": not met" in line] == [False, True]


def test_bench_list_describes_every_benchmark_and_its_data(capsys):
    assert benchmarks.run_benchmark("list") == 0
    out = capsys.readouterr().out
    for name in benchmarks.BENCHMARKS:
        doc, data = benchmarks.describe(name)
        assert doc and "slamarena bench" not in doc.split(":")[0] and "`" not in doc, name
        assert data is not None, f"{name}: the module declares no STAGED_DATA"
        assert f"{name}\n    {doc}\n    {benchmarks.staged_data_line(data)}" in out
    assert "slamarena.experiments.benchmarks" not in out  # entry points are not what a user chooses by


def test_staged_data_line_says_what_is_present():
    assert benchmarks.staged_data_line({}) == "staged data: none (simulated or generated in the run)"
    intel = "present" if resolve("carmen:intel").present() else "absent"
    assert benchmarks.staged_data_line({"carmen:intel": True, "carmen:fr079": False}).startswith(
        f"staged data: needs carmen:intel ({intel}); uses when staged carmen:fr079 ("
    )
