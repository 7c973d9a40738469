"""The dataset registry: a name → loader table, explicit (no import magic beyond the table).

Names (exact forms)::

    utias:<dataset>/robot<k>      e.g. utias:6/robot1        UTIAS MRCLAM
    victoria_park                                            Victoria Park trees
    plaza:<run>                   e.g. plaza:Plaza1          CMU Plaza range-only
    g2o:<name>   isam:<name>                                 pose graphs
    carmen:<name>   carmen-corrected:<name>                  laser logs
    sim:landmarks   sim:localization   sim:laser             simulators (seeded)

``load(name, **params)`` returns a :class:`~slamarena.datasets.sequence.Sequence` or a
:class:`~slamarena.datasets.posegraph.PoseGraph`. Loaders are imported on first use so that the CLI
starts fast. The catalogue of staged real datasets (names, files, kinds) lives in
:mod:`slamarena.datasets.catalogue`.
"""
from __future__ import annotations

from dataclasses import dataclass

from slamarena.errors import UnknownNameError
from slamarena.targets import import_target

from .catalogue import CATALOGUE, CatalogueEntry

__all__ = ["load", "available", "SIMULATORS", "DatasetInfo", "resolve"]

#: simulator name → "module:function"; each declares its parameters as a ``Params`` model (``seed`` among them)
SIMULATORS: dict[str, str] = {
    "sim:landmarks": "slamarena.datasets.sim.landmarks:simulate",
    "sim:localization": "slamarena.datasets.sim.localization:simulate",
    "sim:laser": "slamarena.datasets.sim.laser:simulate",
}


@dataclass(frozen=True)
class DatasetInfo:
    name: str
    kind: str
    ground_truth: str
    present: bool
    files: tuple[str, ...]
    citation: str


def resolve(name: str) -> CatalogueEntry:
    """The catalogue entry of a real dataset name (``KeyError`` listing the valid names)."""
    if name in CATALOGUE:
        return CATALOGUE[name]
    raise UnknownNameError(f"unknown dataset {name!r}; known: {', '.join(sorted(CATALOGUE) + sorted(SIMULATORS))}")


def load(name: str, **params):
    """Load a registered dataset by name; simulators take their parameters as keywords."""
    if name in SIMULATORS:
        return import_target(SIMULATORS[name])(**params)
    entry = resolve(name)
    return entry.load(**params)


def available() -> list[DatasetInfo]:
    """Every registered dataset with its kind, ground truth and whether its files are present."""
    out = [DatasetInfo(n, "simulation", "yes (simulated)", True, (), "") for n in SIMULATORS]
    for name, entry in CATALOGUE.items():
        out.append(DatasetInfo(name, entry.kind, entry.ground_truth, entry.present(), entry.files, entry.citation))
    return out
