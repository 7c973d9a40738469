"""Catalogue of the staged real datasets: registry name → files under the data root and reader.

Each entry names its files relative to a data root, the reader (``"module:function"``,
imported on first use) and the keyword arguments it is called with; the resolved paths are
passed as the keyword ``paths`` (a dict ``role → Path``).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from .dataroot import data_roots, find

__all__ = ["CatalogueEntry", "CATALOGUE"]


@dataclass(frozen=True)
class CatalogueEntry:
    name: str
    kind: str
    ground_truth: str
    files: tuple[str, ...]
    reader: str
    roles: tuple[str, ...] = ()
    arguments: dict = field(default_factory=dict)
    citation: str = ""

    def paths(self) -> dict:
        roles = self.roles or tuple(f"file{k}" for k in range(len(self.files)))
        return {role: find(rel, self.name) for role, rel in zip(roles, self.files)}

    def present(self) -> bool:
        return all(any((root / rel).exists() for root in data_roots()) for rel in self.files)

    def load(self, **params):
        module, _, attr = self.reader.partition(":")
        reader = getattr(importlib.import_module(module), attr)
        return reader(paths=self.paths(), name=self.name, **{**self.arguments, **params})


CATALOGUE: dict[str, CatalogueEntry] = {}
