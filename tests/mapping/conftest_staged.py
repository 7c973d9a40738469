"""Staged real data for the mapping tests (skips when absent)."""

from __future__ import annotations

from functools import lru_cache

import pytest


@lru_cache(maxsize=1)
def _load(name):
    from slamarena import datasets

    return datasets.load(name)


def corrected_intel():
    from slamarena.datasets.errors import DatasetNotFoundError

    try:
        return _load("carmen-corrected:intel").scans
    except (DatasetNotFoundError, KeyError) as exc:
        pytest.skip(f"carmen-corrected:intel not available: {exc}")
