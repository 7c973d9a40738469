"""Where a dataset's files are: a format family's location parameters and the files they name.

A format family (MRCLAM, Victoria Park, CMU Plaza, CARMEN, g2o, TORO, iSAM) has one reader,
``reader(files, name, /, *, params)``, whose parameter model is a :class:`SourceParams`: its
**location** fields (``path`` and, per family, what else picks the files, such as MRCLAM's
``robot``) and its options. :meth:`SourceParams.layout` turns the location into a :class:`Layout`,
role → the file's candidate paths (the first present one is read; MRCLAM's files may be plain or
``.gz``), some roles optional. A path is relative to a data root (a catalogued dataset, or a
relative path a user gives) or absolute. :func:`slamarena.datasets.dataroot.one_root` then takes
every file from the first root that holds all the required ones — never some from one root and
some from another.

A catalogued name fixes its location (``utias:6/robot1`` is Dataset 6's robot 1); the same family
reads any other recording at a path: ``utias:/data/MRCLAM_Dataset7/robot1``, or in a config
``{name: utias, params: {path: /data/MRCLAM_Dataset7, robot: 1}}``
(:func:`slamarena.datasets.registry.resolve`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import PurePosixPath
from typing import ClassVar

from slamarena.params import Params

__all__ = ["Layout", "SourceParams", "joined"]


@dataclass(frozen=True)
class Layout:
    """The files a reader reads: role → candidate paths (the first present one is read), and the optional roles."""

    files: dict[str, tuple[str, ...]]
    optional: frozenset[str] = field(default_factory=frozenset)

    def required(self) -> list[str]:
        return [role for role in self.files if role not in self.optional]

    def needing(self, need: dict[str, bool]) -> Layout:
        """The layout with the roles of ``need`` made required (True) or optional (False)."""
        optional = (self.optional - {r for r, v in need.items() if v}) | {r for r, v in need.items() if not v}
        return Layout(self.files, frozenset(optional & set(self.files)))


def joined(path: str, name: str) -> str:
    """``name`` inside the directory ``path`` (``/`` separated, as the catalogue writes paths)."""
    return str(PurePosixPath(path) / name)


class SourceParams(Params):
    """Base of a format family reader's parameters: where its files are (the ``location`` fields) and its options.

    A subclass declares ``path`` (with what it names: a file, a directory, a run's stem), any other location field,
    lists them in ``location``, and gives :meth:`layout`. A catalogued dataset fixes its location fields; the
    options stay the caller's."""

    #: the fields that say which files are read (a catalogued name fixes them)
    location: ClassVar[tuple[str, ...]] = ("path",)
    #: the form of the ``<text>`` in ``<family>:<text>`` (:meth:`shorthand`)
    form: ClassVar[str] = "<path>"

    @classmethod
    def shorthand(cls, text: str) -> dict:
        """The location fields of the name ``<family>:<text>`` (ValueError naming the expected form)."""
        return {"path": text}

    def spelled(self) -> str:
        """The ``<text>`` of ``<family>:<text>`` that names this location (the inverse of :meth:`shorthand`)."""
        return self.path

    def layout(self) -> Layout:
        raise NotImplementedError

    def options(self, model: type[Params]) -> Params:
        """The fields of ``model`` — a plain reader's own options, which this model adds the location to — as ``model``."""
        return model.of(self.model_dump(include=set(model.model_fields)))
