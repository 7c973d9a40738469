"""The readings of one laser scan, sorted as every laser mapper reads them.

A reading is *bad* when it is NaN, ±inf, zero or negative (rejected and counted); *no return* when it is at
least the sensor's ``max_range`` (it clears space only); *usable* otherwise when shorter than the mapper's
``limit`` (``min(max_range, max_usable_range)``): matched and mapped. Readings between ``limit`` and
``max_range`` are neither.
"""

from __future__ import annotations

import numpy as np

__all__ = ["classify", "scan_counts"]


def classify(ranges: np.ndarray, max_range: float, limit: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boolean masks ``(bad, no_return, usable)`` of the readings ``ranges`` (n,) (module docstring)."""
    finite = np.isfinite(ranges)
    bad = ~finite | (np.where(finite, ranges, 1.0) <= 0)
    no_return = ~bad & (ranges >= max_range)
    usable = ~bad & (ranges < limit)
    return bad, no_return, usable


def scan_counts(diag: dict, n_beams: np.ndarray) -> dict:
    """The per-log counts of an Estimate's ``meta`` from the per-scan ``diag`` (``bad_beams``, ``no_return_beams``,
    ``matched``) and the beams of each scan ``n_beams`` (K,)."""
    return {
        "bad_beams": int(diag["bad_beams"].sum()),
        "scans_with_bad_beams": int((diag["bad_beams"] > 0).sum()),
        "scans_not_matched": int((~diag["matched"]).sum()),
        "scans_all_no_return": int((diag["no_return_beams"] + diag["bad_beams"] == n_beams).sum()),
        "scans_all_bad": int((diag["bad_beams"] == n_beams).sum()),
    }
