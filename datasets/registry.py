"""The dataset registry: names → readers and files, explicit (no import magic beyond the tables).

Names (exact forms)::

    utias:<dataset>/robot<k>      e.g. utias:6/robot1        UTIAS MRCLAM (catalogued: Datasets 1 and 6)
    victoria_park, victoria_park:isam                        Victoria Park trees (GTSAM's / iSAM's copy)
    plaza:<run>                   e.g. plaza:Plaza1          CMU Plaza range-only
    carpark                                                  the ACFR Car Park (raw laser, beacons, GPS)
    g2o:<name>   isam:<name>                                 pose graphs
    carmen:<name>   carmen-corrected:<name>                  laser logs
    bag:<path>                    e.g. bag:/data/run.bag     ROS 1 bags, ROS 2 bag folders, .mcap files
    sim:landmarks   sim:localization   sim:laser             simulators (seeded)

    <family>:<path>               e.g. utias:/data/MRCLAM_Dataset7/robot1, carmen:/data/new.clf
    <family> with params.path     e.g. {name: utias, params: {path: /data/MRCLAM_Dataset7, robot: 1}}

A catalogued name (:data:`~slamarena.datasets.catalogue.CATALOGUE`) is a staged recording: its location
is fixed, its files are found under the data roots (all under one root), the caller's keywords are the
reader's options. Any other recording in a known format is named by its family and path
(:data:`~slamarena.datasets.catalogue.FORMATS`: utias, victoria_park, plaza, g2o, toro, isam, carmen,
carmen-corrected, bag, carpark); a relative path is looked for in the working directory first, then under the data
roots. Either way the reader's ``Params`` model validates every keyword before a file is looked for: an
unknown or bad one is a ``pydantic.ValidationError`` naming it, and a location field given to a
catalogued name, or given twice, is a :class:`~slamarena.datasets.errors.DatasetNameError`.

``load(name, **params)`` returns a :class:`~slamarena.datasets.sequence.Sequence` or a
:class:`~slamarena.datasets.posegraph.PoseGraph`. Loaders are imported on first use so that the CLI
starts fast.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slamarena.errors import UnknownNameError
from slamarena.targets import import_target

from . import dataroot
from .catalogue import CATALOGUE, FORMATS, CatalogueEntry
from .errors import DatasetNameError, DatasetNotFoundError
from .source import Layout, SourceParams

__all__ = ["load", "available", "resolve", "Dataset", "SIMULATORS", "DatasetInfo"]

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


@dataclass(frozen=True)
class Dataset:
    """A real dataset named with its parameters: the reader, its validated parameters, the files and where to look."""

    name: str
    reader: Callable
    params: SourceParams
    layout: Layout
    first: tuple[Path, ...]
    advice: str

    def files(self) -> dict[str, Path]:
        """Role → path, every file from one place (:func:`~slamarena.datasets.dataroot.one_root`)."""
        return dataroot.one_root(self.layout, dataroot.roots(self.first), self.name, self.advice)

    def present(self) -> bool:
        """Some place holds every required file."""
        try:
            self.files()
        except DatasetNotFoundError:
            return False
        return True

    def load(self):
        return self.reader(self.files(), self.name, params=self.params)


def _catalogued(entry: CatalogueEntry, params: dict) -> Dataset:
    family_format = FORMATS[entry.family]
    model = family_format.model()
    fixed = [k for k in params if k in model.location or k in family_format.fixed]
    if fixed:
        preset = family_format.params(entry.arguments)
        raise DatasetNameError(
            f"dataset {entry.name!r} is catalogued, which fixes its files "
            f"({', '.join(f'{k}={getattr(preset, k)!r}' for k in model.location)}): "
            f"{', '.join(fixed)} cannot be given. {_elsewhere(entry.family)}"
        )
    return Dataset(
        entry.name,
        import_target(entry.reader),
        family_format.params({**entry.arguments, **params}),
        entry.layout(),
        (),
        f"Set --data-root or SLAMARENA_DATA, or download it with: slamarena data fetch {entry.name}"
        if entry.fetchable
        else "Set --data-root or SLAMARENA_DATA to a root holding it (staged only: no download).",
    )


def _elsewhere(family: str) -> str:
    """How to name a recording of ``family`` that is not catalogued (for messages)."""
    family_format = FORMATS[family]
    model = family_format.model()
    fields = ", ".join(f"{k}: …" for k in model.location if model.model_fields[k].is_required())
    catalogued = sorted(n for n, e in CATALOGUE.items() if e.family == family)
    return (
        f"Any {family} recording: {family}:{model.form} (e.g. {family_format.example}), "
        f"or in a config {{name: {family}, params: {{{fields}}}}}, "
        f"where <path> is {model.model_fields['path'].description}; a relative path is looked for in the working directory, "
        f"then under the data roots." + (f" Catalogued: {', '.join(catalogued)}." if catalogued else "")
    )


def _at_path(name: str, family: str, text: str | None, params: dict) -> Dataset:
    family_format = FORMATS[family]
    location = {}
    if text is not None:
        try:
            location = family_format.model().shorthand(text)
        except ValueError as exc:
            raise DatasetNameError(f"dataset {name!r}: {exc}. {_elsewhere(family)}") from None
    twice = sorted(set(params) & (set(location) | set(family_format.fixed)))
    if twice:
        raise DatasetNameError(
            f"dataset {name!r} already sets {', '.join(twice)}; give it once (in the name or in params)"
        )
    p = family_format.params({**location, **params})
    fields = set(p.location)
    same = [
        n
        for n, e in CATALOGUE.items()
        if e.family == family
        and family_format.params(e.arguments).model_dump(include=fields) == p.model_dump(include=fields)
    ]
    fetch = f" These are the files of the catalogued {same[0]}: slamarena data fetch {same[0]}" if same else ""
    return Dataset(
        name if text is not None else f"{family}:{p.spelled()}",
        import_target(family_format.reader),
        p,
        p.layout(),
        (Path.cwd(),),
        _elsewhere(family) + fetch,
    )


def resolve(name: str, params: Mapping[str, Any] | None = None) -> Dataset:
    """The real dataset ``name`` with ``params`` (validated; no file is looked for yet).

    A catalogued name, else ``<family>:<path>`` or ``<family>`` with ``params.path`` (a family name that is also
    catalogued, ``victoria_park``, is the catalogued dataset unless ``params`` give a path)."""
    params = dict(params or {})
    family, colon, text = name.partition(":")
    if name in CATALOGUE and not (name in FORMATS and "path" in params):
        return _catalogued(CATALOGUE[name], params)
    if family in FORMATS and (text or not colon):
        return _at_path(name, family, text or None, params)
    raise UnknownNameError(
        f"unknown dataset {name!r}; known: {', '.join(sorted(CATALOGUE) + sorted(SIMULATORS))}; "
        f"or a recording at a path: <family>:<path> with a family of {', '.join(FORMATS)} (e.g. {FORMATS['utias'].example})"
    )


def load(name: str, **params):
    """Load a dataset by name; simulators take their parameters as keywords, readers their options."""
    if name in SIMULATORS:
        return import_target(SIMULATORS[name])(**params)
    return resolve(name, params).load()


def available() -> list[DatasetInfo]:
    """Every registered dataset with its kind, ground truth and whether its files are present."""
    out = [DatasetInfo(n, "simulation", "yes (simulated)", True, (), "") for n in SIMULATORS]
    for name, entry in CATALOGUE.items():
        out.append(
            DatasetInfo(name, entry.kind, entry.ground_truth, resolve(name).present(), entry.files, entry.citation)
        )
    return out
