"""Shared fixtures: locating the staged real datasets the way the package does."""
from __future__ import annotations

from pathlib import Path

import pytest

from datasets.dataroot import data_roots


def staged(relative: str) -> Path:
    """Path of a staged dataset file under the data root; skips the test when it is absent."""
    for root in data_roots():
        if (root / relative).exists():
            return root / relative
    pytest.skip(f"dataset file {relative} is not under any data root (set SLAMARENA_DATA)")


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)
