"""Statistical assertions shared by the tests (import as ``from checks import ...``; pytest puts
``tests/`` on the path for its conftest)."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats


def assert_gaussian(residuals: np.ndarray, sigma: float, p: float = 1e-4) -> None:
    """Residuals look like N(0, σ²): |sample mean| within the normal quantile and the sample
    variance inside the two-sided χ² interval, both at false-alarm probability ``p``."""
    e = np.asarray(residuals, dtype=float)
    n = e.size
    z = stats.norm.ppf(1 - p / 2)
    assert abs(e.mean()) <= z * sigma / math.sqrt(n), (e.mean(), sigma, n)
    lo, hi = stats.chi2.ppf([p / 2, 1 - p / 2], n - 1) / (n - 1)
    ratio = e.var(ddof=1) / sigma**2
    assert lo <= ratio <= hi, (ratio, lo, hi)
