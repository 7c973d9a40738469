"""The distribution: one ``slamarena`` namespace mapped from the design's root folders, nothing else installed at top level."""

from __future__ import annotations

import importlib.metadata
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("datasets", "estimators", "mapping", "experiments", "paper_figures")


def _pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_every_package_folder_is_mapped_into_the_namespace():
    setuptools = _pyproject()["tool"]["setuptools"]
    expected = {"slamarena"} | {
        "slamarena." + ".".join(init.parent.relative_to(ROOT).parts)
        for folder in FOLDERS
        for init in (ROOT / folder).rglob("__init__.py")
    }
    assert set(setuptools["packages"]) == expected
    assert setuptools["package-dir"] == {"slamarena": "slamarena", **{f"slamarena.{f}": f for f in FOLDERS}}


def test_the_version_has_one_source():
    import slamarena

    assert _pyproject()["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "slamarena.__version__"}
    assert importlib.metadata.version("slamarena") == slamarena.__version__


def test_the_wheel_installs_under_slamarena_only(tmp_path):
    """The built wheel holds the package, its metadata and the shipped configs, and nothing at top level that
    could overwrite another distribution's files (``datasets/`` above all)."""
    source = tmp_path / "source"  # a copy, so that the build leaves nothing in the checkout
    for folder in ("slamarena", *FOLDERS):
        shutil.copytree(ROOT / folder, source / folder, ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(source),
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    (wheel,) = tmp_path.glob("slamarena-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    import slamarena

    assert tops == {"slamarena", f"slamarena-{slamarena.__version__}.dist-info"}, tops
    assert "slamarena/experiments/configs/default.yaml" in names
    assert "slamarena/datasets/sim/landmarks.py" in names
    entry_points = zipfile.ZipFile(wheel).read(f"slamarena-{slamarena.__version__}.dist-info/entry_points.txt").decode()
    assert "slamarena = slamarena.experiments.cli:main" in entry_points


def test_notebook_names_load_lazily():
    code = (
        "import sys, slamarena; assert 'slamarena.datasets' not in sys.modules; "
        "s = slamarena.load('sim:landmarks', n_landmarks=5, laps=1, seed=0); "
        "assert isinstance(s, slamarena.Sequence); e = slamarena.create('dead_reckoning').run(s); "
        "assert isinstance(e, slamarena.Estimate); print(slamarena.__version__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd="/")
    assert out.returncode == 0, out.stderr
    import slamarena

    assert out.stdout.strip() == slamarena.__version__


def test_import_target_names_the_bad_string():
    import pytest

    from slamarena import import_target

    assert import_target("slamarena.datasets.geometry:wrap_angle")(4.0) == __import__("pytest").approx(
        4.0 - 2 * 3.141592653589793
    )
    with pytest.raises(ValueError, match="package.module:attribute"):
        import_target("slamarena.datasets.geometry.wrap_angle")
