"""The layering of ARCHITECTURE.md, checked on the source: datasets → (estimators, mapping) → experiments → paper_figures."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LAYER = {"datasets": 0, "estimators": 1, "mapping": 1, "experiments": 2, "paper_figures": 3}
DATASETS_MAY_IMPORT = {"numpy", "pooch", "gtsam"}  # pooch only inside fetch, gtsam only to locate the wheel's example data


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.append((node.lineno, node.module))
    return out


def _sources(package: str):
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", [p for p in LAYER if p != "paper_figures"])
def test_no_package_imports_from_a_layer_above_it(package):
    offences = []
    for path in _sources(package):
        for line, module in _imports(path):
            top = module.split(".")[0]
            if top in LAYER and LAYER[top] > LAYER[package] and not (package == "experiments" and path.name == "cli.py" and top == "paper_figures"):
                offences.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
            if {package, top} == {"estimators", "mapping"}:
                offences.append(f"{path.relative_to(ROOT)}:{line} imports {module} (a side-by-side layer)")
    assert not offences, "\n".join(offences)


def test_datasets_depends_on_numpy_and_the_standard_library_only():
    stdlib = set(sys.stdlib_module_names)
    offences = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for path in _sources("datasets")
        for line, module in _imports(path)
        if module.split(".")[0] not in stdlib | DATASETS_MAY_IMPORT | {"datasets"}
    ]
    assert not offences, "\n".join(offences)


def test_cli_help_loads_no_heavy_library():
    code = (
        "import sys; from experiments import cli; "
        "heavy = [m for m in ('gtsam', 'open3d', 'kiss_icp', 'filterpy', 'numba', 'matplotlib', 'pandas', 'scipy', 'dask') if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "", f"importing the CLI loaded: {result.stdout.strip()}"
