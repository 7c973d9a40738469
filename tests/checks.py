"""Helpers shared by the tests: locating staged datasets, statistical assertions and covariance comparisons.

Import as ``from checks import ...`` (pyproject's pytest ``pythonpath`` puts ``tests/`` on the path, after the
repository root so that ``datasets`` is the package, not ``tests/datasets``)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError
from scipy import stats

from slamarena.datasets.dataroot import locate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.datasets.sequence import BeaconRanges, Sequence


def staged(relative: str) -> Path:
    """Path of a staged dataset file (under a data root, or the GTSAM wheel's copy); skips the test when it is absent."""
    path = locate(relative)
    if path is None:
        pytest.skip(f"dataset file {relative} is not under any data root (set SLAMARENA_DATA)")
    return path


def load_staged(name: str, **params):
    """``slamarena.datasets.load(name, **params)`` of a catalogued real dataset; skips the test when a file it reads is absent."""
    from slamarena.datasets import DatasetNotFoundError
    from slamarena.datasets.registry import load

    try:
        return load(name, **params)
    except DatasetNotFoundError as missing:
        pytest.skip(f"dataset file {missing.relative} of {name} is not under any data root (set SLAMARENA_DATA)")


def assert_rejected_naming(call, **bad) -> None:
    """``call(**bad)`` raises :class:`pydantic.ValidationError` (a ValueError) naming the first key of ``bad``: as
    the location of every error, or in the message of a rule joining fields (a model validator's error has none)."""
    field = next(iter(bad))
    with pytest.raises(ValidationError) as err:
        call(**bad)
    for e in err.value.errors():
        assert e["loc"][0] == field if e["loc"] else field in e["msg"], e


def assert_covariances_close(actual: np.ndarray, desired: np.ndarray, rtol: float) -> None:
    """Each covariance of ``actual`` (..., d, d) equals the one of ``desired`` to ``rtol`` in that covariance's own
    metric: with B = L Lᵀ, every eigenvalue of L⁻¹ (A − B) L⁻ᵀ lies within ±rtol, i.e. |uᵀ(A − B)u| ≤ rtol · uᵀBu for every
    direction u — the relative error of the variance along each direction. Independent of units, scale and
    conditioning (a tolerance relative to the largest entry would not test the small-variance directions at all and
    fails on a round-off that a better-conditioned entry would absorb): it tests the claim, not the BLAS."""
    A, B = np.asarray(actual, dtype=float), np.asarray(desired, dtype=float)
    assert A.shape == B.shape and A.shape[-1] == A.shape[-2], (A.shape, B.shape)
    L = np.linalg.cholesky(B)
    D = np.linalg.solve(L, np.swapaxes(np.linalg.solve(L, A - B), -1, -2))
    worst = np.abs(np.linalg.eigvalsh(0.5 * (D + np.swapaxes(D, -1, -2)))).max(axis=-1)
    k = np.unravel_index(np.argmax(worst), worst.shape) if worst.ndim else ()
    assert np.max(worst) <= rtol, f"covariance {k}: relative difference {np.max(worst):.3g} > {rtol:g}"


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


def assert_dead_reckoning_consistent(sequences, p: float = 1e-3) -> None:
    """Dead reckoning with a sequence's stated noise is consistent: the final-pose NEES averaged
    over the (independent, seeded) sequences lies inside the two-sided χ² band at level ``p``."""
    from slamarena.datasets.geometry import wrap_angle
    from slamarena.estimators.dead_reckoning import DeadReckoning

    nees = []
    for s in sequences:
        e = DeadReckoning().run(s)
        d = e.poses[-1] - s.ground_truth.poses[-1]
        d[2] = wrap_angle(d[2])
        nees.append(d @ np.linalg.solve(e.pose_cov[-1], d))
    runs = len(nees)
    lo, hi = stats.chi2.ppf([p, 1 - p], 3 * runs) / runs
    assert lo <= np.mean(nees) <= hi, (np.mean(nees), lo, hi)


def with_beacon_ranges(seq: Sequence, sigma: float, bias: float = 0.0, seed: int = 0) -> Sequence:
    """``seq`` with its range-bearing rows turned into range-only rows to the same landmarks:
    true range (ground truth interpolated at the stamp) + ``bias`` + N(0, ``sigma``²)."""
    rb = seq.range_bearing
    truth = interpolate_poses(seq.ground_truth.t, seq.ground_truth.poses, rb.t)
    xy = seq.landmarks.xy[np.searchsorted(seq.landmarks.ids, rb.landmark_id)]
    r = np.hypot(*(xy - truth[:, :2]).T) + bias + sigma * np.random.default_rng(seed).standard_normal(len(rb))
    return dataclasses.replace(
        seq, range_bearing=None, beacon_ranges=BeaconRanges(t=rb.t, range=r, beacon_id=rb.landmark_id)
    )
