"""RANSAC's adaptive number of iterations (Fischler & Bolles 1981; Hartley & Zisserman 2004, §4.7.1).

With the best inlier fraction ``w`` seen so far and a minimal sample of ``s`` correspondences, a sample is all
inliers with probability ``w^s``; ``N`` samples miss every all-inlier sample with probability ``(1 − w^s)^N``.
Requiring that to be at most ``1 − p`` (``p`` the confidence)::

    N(w) = ⌈ log(1 − p) / log(1 − w^s) ⌉        (capped at ``max_iterations``)

The loop re-evaluates ``N`` whenever a sample finds more inliers, and stops once it has drawn ``N``.
"""

from __future__ import annotations

import math

import numba

__all__ = ["iterations_needed"]


@numba.njit(cache=True)
def iterations_needed(inlier_fraction: float, sample_size: int, confidence: float, max_iterations: int) -> int:
    """N(w) above, in [1, max_iterations] (compiled: the hypothesis loops of :mod:`.pnp` call it)."""
    good = inlier_fraction**sample_size
    if good >= 1.0:
        return 1
    if good <= 0.0:
        return max_iterations
    n = math.log(1.0 - confidence) / math.log1p(-good)
    return int(min(max_iterations, max(1, math.ceil(n))))
