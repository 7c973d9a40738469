"""The layering the README states ("Layout"), checked on the source: datasets → (estimators, mapping) → experiments → paper_figures,
all under the one ``slamarena`` namespace (no module imports a top-level ``datasets``, ``estimators``, …)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LAYER = {"datasets": 0, "estimators": 1, "mapping": 1, "experiments": 2, "paper_figures": 3}
BASE = {
    "slamarena",
    "slamarena.targets",
    "slamarena.params",
    "slamarena.errors",
    "slamarena.robust",
    "slamarena.resources",
}  # the namespace's own modules, below every layer
DATASETS_MAY_IMPORT = {
    "numpy",
    "scipy",
    "pydantic",
    "pooch",
    "gtsam",
    "rosbags",
    "cv2",
    "pandas",
    "lz4",
    "backports",
    "compression",
}  # scipy.io for MAT files, pydantic for parameter models, pooch only inside fetch, gtsam only to locate the wheel's example
# data, rosbags only inside the ROS bag and MCAP readers and writers (formats/bag*.py, ros_results.py), cv2 (imported on
# first use) only to decode a camera image when one is asked for, pandas only inside formats/_text.py (its C parser
# converts the numbers of every text reader), lz4 and zstd (rosbags' own decompressors: lz4, backports.zstd or Python
# 3.14's compression.zstd) only in formats/bag_damage.py, to read the chunks of a bag that rosbags cannot open


def _imports(path: Path) -> list[tuple[int, str]]:
    """Every absolute import of ``path`` as (line, dotted module); ``from slamarena import x`` counts as ``slamarena.x``."""
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == "slamarena":
                out += [(node.lineno, f"slamarena.{alias.name}") for alias in node.names]
            else:
                out.append((node.lineno, node.module))
    return out


def _layer_of(module: str) -> str | None:
    """The layer a ``slamarena.<package>…`` import belongs to (None for the namespace's own modules and other libraries)."""
    parts = module.split(".")
    return parts[1] if parts[0] == "slamarena" and len(parts) > 1 and parts[1] in LAYER else None


def _sources(package: str):
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", [p for p in LAYER if p != "paper_figures"])
def test_no_package_imports_from_a_layer_above_it(package):
    offences = []
    for path in _sources(package):
        for line, module in _imports(path):
            top = _layer_of(module)
            if top is None:
                continue
            if LAYER[top] > LAYER[package] and not (
                package == "experiments" and path.name == "cli.py" and top == "paper_figures"
            ):
                offences.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
            if {package, top} == {"estimators", "mapping"}:
                offences.append(f"{path.relative_to(ROOT)}:{line} imports {module} (a side-by-side layer)")
    assert not offences, "\n".join(offences)


def test_nothing_imports_a_top_level_package_name():
    """``datasets``, ``estimators``, ``mapping``, ``experiments`` are other projects' names on the package index."""
    offences = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for folder in [*LAYER, "slamarena", "tests"]
        for path in _sources(folder)
        for line, module in _imports(path)
        if module.split(".")[0] in LAYER
    ]
    assert not offences, "\n".join(offences)


def test_datasets_depends_on_numpy_scipy_pydantic_rosbags_and_the_standard_library_only():
    stdlib = set(sys.stdlib_module_names)
    offences = [
        f"{path.relative_to(ROOT)}:{line} imports {module}"
        for path in _sources("datasets")
        for line, module in _imports(path)
        if module.split(".")[0] not in stdlib | DATASETS_MAY_IMPORT
        and module not in BASE
        and _layer_of(module) != "datasets"
    ]
    assert not offences, "\n".join(offences)


def test_cli_help_loads_no_heavy_library():
    code = (
        "import sys; from slamarena.experiments import cli; "
        "heavy = [m for m in ('gtsam', 'open3d', 'kiss_icp', 'filterpy', 'numba', 'matplotlib', 'pandas', 'scipy', 'dask') "
        "if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "", f"importing the CLI loaded: {result.stdout.strip()}"
