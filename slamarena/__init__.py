"""slamarena — a comparative SLAM research framework.

Everything is imported under this one name: :mod:`slamarena.datasets`, :mod:`slamarena.estimators`,
:mod:`slamarena.mapping`, :mod:`slamarena.experiments`, :mod:`slamarena.paper_figures`. In the
repository those packages are the folders at the root (the layout the design fixes); the install maps
them here (``package-dir`` in pyproject.toml, research/design.md "The slamarena namespace").

For a notebook, the few names most scripts need::

    import slamarena
    seq = slamarena.load("sim:landmarks", n_landmarks=60, seed=3)    # a Sequence
    est = slamarena.create("ekf_slam").run(seq)                      # an Estimate

They are imported on first use, so ``import slamarena`` stays cheap.
"""

from __future__ import annotations

from pathlib import Path as _Path

__version__ = "0.2.0"
__all__ = ["__version__", "load", "available", "create", "Sequence", "PoseGraph", "Estimate", "import_target"]

from .targets import import_target  # noqa: E402  (the one "module:attr" resolver, used by every registry)

_checkout = _Path(__file__).resolve().parent.parent
if (_checkout / "pyproject.toml").is_file() and (_checkout / "datasets" / "__init__.py").is_file():
    # Imported from a source checkout (e.g. Python started at the repository root, which puts this folder
    # first on sys.path): the subpackages are the folders beside this one, exactly as the install maps them.
    __path__.append(str(_checkout))

_LAZY = {
    "load": "slamarena.datasets:load",
    "available": "slamarena.datasets:available",
    "Sequence": "slamarena.datasets:Sequence",
    "PoseGraph": "slamarena.datasets:PoseGraph",
    "Estimate": "slamarena.datasets:Estimate",
    "create": "slamarena.estimators:create",
}


def __getattr__(name: str):
    if name in _LAZY:
        value = import_target(_LAZY[name])
        globals()[name] = value
        return value
    raise AttributeError(f"module 'slamarena' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
