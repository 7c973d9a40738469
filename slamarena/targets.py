"""The one resolver of registry targets: every registry (datasets, simulators, estimators, mappers,
matchers, benchmarks) names what it builds as a ``"package.module:attribute"`` string, imported on
first use so that a command loads only the libraries the work needs."""

from __future__ import annotations

import importlib

__all__ = ["import_target"]


def import_target(target: str):
    """The attribute named by ``"package.module:attribute"`` (``ValueError`` when the string has no ``:``)."""
    module, sep, attr = target.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"a registry target reads 'package.module:attribute', got {target!r}")
    return getattr(importlib.import_module(module), attr)
