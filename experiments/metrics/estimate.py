"""What an estimate reports about itself, without ground truth: its size and the method's own counts.

* ``landmarks``: landmarks in the final map (``len(Estimate.landmark_ids)``; unavailable for a method without a map
  of landmarks) — with ids withheld, the count to hold against the true one.
* ``rejected``: input rows the method refused: the sum of its scalar ``diagnostics["rejected_*"]`` counts (bad rows:
  non-finite, negative range, invalid covariance, …) plus ``meta["rejected"]`` where that is a count (EKF-SLAM: rows
  its χ² gate refused).
* ``initial_error``, ``final_error``, ``iterations``: an optimiser's ½ Σ eᵀ Ω e before and after and its iteration
  count (``diagnostics``), so a run that stops in a local minimum shows its cost beside the others'.
* ``resamplings``: a particle filter's resampling events (``meta["resamplings"]``).

None of them is marked best in a table: fewer rejections or a lower ½χ² of another graph is not better by itself.
An output the estimate does not carry is left out of the row (the table shows –); the metric is unavailable only when
the estimate carries none of them.
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.params import Params

from .reference import MetricUnavailable

__all__ = ["EstimateParams", "estimate_counts", "ESTIMATE_OUTPUTS"]


class EstimateParams(Params):
    """The estimate-count metric takes no parameters."""


ESTIMATE_OUTPUTS = {
    "landmarks": (None, "landmarks in the final map"),
    "rejected": (None, "input rows the method rejected (bad rows, and rows its gate refused)"),
    "initial_error": (None, "optimiser's ½ Σ eᵀΩe at its start"),
    "final_error": (None, "optimiser's ½ Σ eᵀΩe at its end"),
    "iterations": (None, "optimiser iterations"),
    "resamplings": (None, "particle-filter resampling events"),
}


def _scalar(value) -> float | None:
    array = np.asarray(value)
    return float(array) if array.ndim == 0 and np.issubdtype(array.dtype, np.number) else None


def estimate_counts(estimate: Estimate, params: EstimateParams = EstimateParams()) -> tuple[dict, dict]:
    out: dict = {}
    if estimate.landmark_ids is not None:
        out["landmarks"] = int(len(estimate.landmark_ids))
    counts = [v for k, v in estimate.diagnostics.items() if k.startswith("rejected_") and _scalar(v) is not None]
    gated = estimate.meta.get("rejected")
    if counts or isinstance(gated, int):
        out["rejected"] = int(sum(_scalar(v) for v in counts) + (gated if isinstance(gated, int) else 0))
    for key in ("initial_error", "final_error", "iterations"):
        value = _scalar(estimate.diagnostics[key]) if key in estimate.diagnostics else None
        if value is not None:
            out[key] = int(value) if key == "iterations" else value
    if isinstance(estimate.meta.get("resamplings"), int):
        out["resamplings"] = estimate.meta["resamplings"]
    if not out:
        raise MetricUnavailable(f"{estimate.method} reports no landmarks, rejections, optimiser errors or resamplings")
    return out, {}
