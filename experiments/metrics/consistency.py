"""Filter consistency: NEES and NIS against their χ² bands (Bar-Shalom, Li, Kirubarajan 2001, §5.4).

NEES of a pose estimate with covariance ``P_k`` (3, 3) and error ``e_k``::

    ε_k = e_kᵀ P_k⁻¹ e_k  ~  χ²(3) for a consistent estimator

The error must be expressed where the covariance lives:

* ``frame: world`` (default; EKFs, dead reckoning): ``e = (x̂ − x, ŷ − y, wrap(θ̂ − θ))``.
* ``frame: body`` (GTSAM ``Pose2`` marginals, which are in the tangent space at the estimate:
  ``x = x̂ ⊕ Exp(ξ)``): ``e = Log(x̂⁻¹ x)``, the SE(2) logarithm of the true pose seen from the
  estimate.

Steps whose covariance is not finite or is (numerically) singular — condition number above
``max_condition``, e.g. the rank-2 covariance of dead reckoning after its first step — are
skipped: their NEES measures rounding, not consistency.

NIS of an innovation ``ν`` with covariance ``S`` (dimension m): ``ν_kᵀ S_k⁻¹ ν_k ~ χ²(m)``.
Estimators report it in ``Estimate.diagnostics`` as ``nis`` (M,), ``nis_dof`` (M,) and,
optionally, ``nis_t`` (M,) (stamps).

Bands. One run: two-sided 95 % interval of χ²(d): ``[χ²_d(0.025), χ²_d(0.975)]``. Over N Monte
Carlo runs the average ``ε̄_k = (1/N) Σ_i ε_k^i`` has ``N ε̄_k ~ χ²(N d)``, so the band is
``[χ²_{Nd}(0.025), χ²_{Nd}(0.975)] / N``. The reported ``in_band`` is the fraction of steps
whose (average) value lies inside; a consistent filter has ≈ 0.95 (one run) and most steps
inside (averaged).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, se2_log, wrap_angle
from slamarena.params import Params

from .reference import MetricUnavailable, Reference, associate

__all__ = [
    "NEESParams",
    "NISParams",
    "chi2_band",
    "nees",
    "nis",
    "nis_per_stamp",
    "monte_carlo",
    "NEES_OUTPUTS",
    "NIS_OUTPUTS",
]


class NEESParams(Params):
    frame: Literal["world", "body"] = "world"
    max_gap: float = Field(0.1, ge=0)
    max_condition: float = Field(
        1e9, gt=1, description="steps whose covariance has a larger condition number are skipped"
    )
    probability: float = Field(0.95, gt=0, lt=1)


class NISParams(Params):
    probability: float = Field(0.95, gt=0, lt=1)


NEES_OUTPUTS = {
    "mean": (None, "mean NEES over the steps (3 for a consistent filter)"),
    "mean_over_dof": (None, "mean NEES / 3 (1 for a consistent filter)"),
    "in_band": ("higher", "fraction of steps inside the single-run χ²(3) band"),
    "steps": (None, "steps with ground truth and a covariance"),
}
NIS_OUTPUTS = {
    "mean_over_dof": (None, "mean of NIS / dof (1 for a consistent filter)"),
    "in_band": ("higher", "fraction of innovations inside the χ²(dof) band"),
    "count": (None, "number of innovations"),
}


def chi2_band(dof, runs: int = 1, probability: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided band of the run-average of χ²(dof) statistics over ``runs`` runs."""
    from scipy.special import gammaincinv  # χ²_k quantile q = 2·P⁻¹(k/2, q); lighter than scipy.stats

    alpha = 1.0 - probability
    k = runs * np.asarray(dof, dtype=float)
    return 2.0 * gammaincinv(k / 2, alpha / 2) / runs, 2.0 * gammaincinv(k / 2, 1 - alpha / 2) / runs


def pose_error(estimate_poses: np.ndarray, true_poses: np.ndarray, frame: str) -> np.ndarray:
    """The error e (K, 3) whose covariance the estimate states (see the module docstring)."""
    if frame == "world":
        e = np.asarray(estimate_poses, dtype=float) - true_poses
        e[:, 2] = wrap_angle(e[:, 2])
        return e
    return se2_log(between(estimate_poses, true_poses))


def nees(estimate: Estimate, ref: Reference, params: NEESParams = NEESParams()) -> tuple[dict, dict]:
    """Per-step pose NEES and its summary (single run)."""
    if estimate.pose_cov is None:
        raise MetricUnavailable(f"{estimate.method} reports no pose covariance")
    assoc = associate(ref, estimate.t, params.max_gap)
    P = estimate.pose_cov[assoc.index]
    finite = np.all(np.isfinite(P.reshape(len(P), -1)), axis=1)
    w = np.linalg.eigvalsh(np.where(finite[:, None, None], P, np.eye(3)))
    usable = finite & (w[:, 0] > params.max_condition**-1 * w[:, -1])
    if not usable.any():
        raise MetricUnavailable("no step has ground truth and a well-conditioned covariance")
    e = pose_error(estimate.poses[assoc.index][usable], assoc.gt[usable], params.frame)
    eps = np.einsum("ki,ki->k", e, np.linalg.solve(P[usable], e[..., None])[..., 0])
    lo, hi = chi2_band(3, 1, params.probability)
    out = {
        "mean": float(eps.mean()),
        "mean_over_dof": float(eps.mean() / 3),
        "in_band": float(np.mean((eps >= lo) & (eps <= hi))),
        "steps": int(eps.size),
    }
    return out, {"t": estimate.t[assoc.index][usable], "nees": eps}


def nis(estimate: Estimate, params: NISParams = NISParams()) -> tuple[dict, dict]:
    """Summary of the NIS values an estimator recorded in its diagnostics."""
    d = estimate.diagnostics
    if "nis" not in d or "nis_dof" not in d:
        raise MetricUnavailable(f"{estimate.method} records no NIS (diagnostics 'nis' and 'nis_dof')")
    value = np.asarray(d["nis"], dtype=float).reshape(-1)
    dof = np.broadcast_to(np.asarray(d["nis_dof"], dtype=float), value.shape)
    ok = np.isfinite(value)
    if not ok.any():
        raise MetricUnavailable("no finite NIS value")
    lo, hi = chi2_band(dof[ok], 1, params.probability)
    v = value[ok]
    t = np.asarray(d["nis_t"], dtype=float).reshape(-1)[ok] if "nis_t" in d else np.flatnonzero(ok).astype(float)
    out = {
        "mean_over_dof": float(np.mean(v / dof[ok])),
        "in_band": float(np.mean((v >= lo) & (v <= hi))),
        "count": int(v.size),
    }
    return out, {"t": t, "nis": v, "dof": dof[ok]}


def nis_per_stamp(t: np.ndarray, value: np.ndarray, dof: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sum the NIS and dimensions of the innovations sharing a stamp (a sum of independent
    χ² values is χ² with the summed dimension): (stamps, NIS sums, dof sums)."""
    t = np.asarray(t, dtype=float)
    order = np.argsort(t, kind="stable")
    t, value, dof = t[order], np.asarray(value, dtype=float)[order], np.asarray(dof, dtype=float)[order]
    first = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    return t[first], np.add.reduceat(value, first), np.add.reduceat(dof, first)


def monte_carlo(runs: list[tuple], dof=3, probability: float = 0.95, tol: float = 1e-6) -> dict:
    """Average a χ² statistic over N runs at the stamps all runs share; band for N runs.

    ``runs`` is a list of ``(t, value)`` with a common dimension ``dof``, or of
    ``(t, value, dof_per_stamp)`` (NIS: :func:`nis_per_stamp`), in which case only the stamps
    where every run has the same dimension are kept. Stamps match to ``tol`` seconds.
    Returns ``t, mean, lo, hi, dof, in_band, runs``.
    """
    if not runs:
        raise MetricUnavailable("no runs to average")
    tables = []
    for run in runs:
        t, value = np.asarray(run[0], dtype=float), np.asarray(run[1], dtype=float)
        d = np.broadcast_to(np.asarray(run[2] if len(run) > 2 else dof, dtype=float), t.shape)
        tables.append(dict(zip(np.round(t / tol).tolist(), zip(value.tolist(), d.tolist()))))
    t0 = np.asarray(runs[0][0], dtype=float)
    keys = np.round(t0 / tol).tolist()
    shared = np.array(
        [all(k in table and table[k][1] == tables[0][k][1] for table in tables) for k in keys], dtype=bool
    )
    if not shared.any():
        raise MetricUnavailable("the runs share no time stamp (with equal dimension)")
    kept = [k for k, s in zip(keys, shared) if s]
    mean = np.mean([[table[k][0] for k in kept] for table in tables], axis=0)
    dims = np.array([tables[0][k][1] for k in kept])
    lo, hi = chi2_band(dims, len(runs), probability)
    inside = (mean >= lo) & (mean <= hi)
    return {
        "t": t0[shared],
        "mean": mean,
        "lo": lo,
        "hi": hi,
        "dof": dims,
        "in_band": float(np.mean(inside)),
        "runs": len(runs),
    }
