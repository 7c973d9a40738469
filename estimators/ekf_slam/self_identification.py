"""Self-identification of EKF-SLAM's noise scales without ids (``run()`` with ``use_ids=False``, ``self_identify``;
research/method/ekf_slam_adaptive_noise.md).

Model: the stated noise is right up to two scales, ``Q_k → q · Q_k`` for every prediction piece (3 × 3, the control- or
increment-space noise mapped to the robot, or the additive one) and ``R_j → r · R_j`` for every observation row (2 × 2).

1. **Test** (one run on the stated model, q = r = 1). A matched row's NIS ``d²_j = ν_jᵀ S_j⁻¹ ν_j`` (ν (2,), S (2 × 2))
   is, under the model, χ²₂ truncated to the match gate g = χ²₂(match_confidence), so
   ``u_j = F(d²_j) / F(g) ~ U(0, 1)`` (F the χ²₂ distribution function). Median (sign) test over the n matched rows:
   ``k = #{u_j < ½}``, ``z = (k − n/2) / √(n/4)``; the stated model is rejected when ``|z| > Φ⁻¹(1 − α/2)``,
   α = 1 − noise_confidence. The median is untouched by the heavy tail the gates cut (research/notebook/
   2026-11-23-ekf-slam-victoria-park.md, script NS), and it tests the whole innovation covariance S = H P Hᵀ + R.
2. **Search** (only when rejected). ``(log q, log r) = log(noise_factor) · (i, j)``, i, j ∈ {−noise_steps … noise_steps};
   each point is a full run scored by its log-likelihood without ids, the prediction-error decomposition the look-ahead
   association scores with (``EKFSLAM.log_likelihood``: a matched row ``log N(ν; 0, S)``, a new or rejected row the
   density λ₀ of a perfectly known landmark at the new-landmark gate). Coordinate line search: the whole r line at the
   current q, then the whole q line at the best r, until a sweep moves neither (a line, not a neighbour step: without
   ids the likelihood is not unimodal along a line, because the association changes with the noise).
3. **Choice**: the best point, if ``2 (L_best − L(1, 1)) > χ²₂(noise_confidence)`` (two scales estimated); else the
   stated model. The filter ends in the state of the run chosen (``EKFSLAM.q_scale``, ``r_scale``).

Cost: one run when the stated model passes the test; otherwise one run per grid point visited (at most
(2·noise_steps + 1)² = 49 at the default).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.stats import chi2, norm

from ..models import chi2_gate

__all__ = ["median_test", "identify"]


def median_test(nis: np.ndarray, gate: float, confidence: float) -> tuple[bool, float]:
    """Whether NIS values (n,) of 2-dof innovations gated below ``gate`` reject their model at ``confidence``, and the
    test's z (module docstring, step 1). No rows: not rejected, z = 0."""
    nis = np.asarray(nis, dtype=float)
    n = nis.size
    if not n:
        return False, 0.0
    k = np.count_nonzero(chi2.cdf(nis, 2) < 0.5 * chi2.cdf(gate, 2))
    z = (k - 0.5 * n) / np.sqrt(0.25 * n)
    return bool(abs(z) > norm.ppf(1 - 0.5 * (1 - confidence))), float(z)


def matched_nis(ekf) -> np.ndarray:
    """The NIS of the filter's 2-dof updates (its matched rows, one update per row)."""
    log = np.array(ekf.nis_log, dtype=float).reshape(-1, 2)
    return log[log[:, 1] == 2, 0]


def identify(ekf, sequence, estimate, walk: Callable) -> object:
    """Steps 1–3 of the module docstring for a filter that has just run ``sequence`` on its stated noise (``estimate``);
    ``walk(filter, sequence, q, r)`` runs a filter over the sequence from its reset with the scales q, r and returns its
    estimate. Returns the estimate of the run chosen (``meta["noise_identification"]``: the test, the
    grid points run with their log-likelihoods, the scales chosen) and leaves ``ekf`` in that run's state."""
    p = ekf.params
    rejected, z = median_test(matched_nis(ekf), ekf.gate_match, p.noise_confidence)
    record = {"median_z": z, "rejected": rejected, "runs": [[0, 0, ekf.log_likelihood]], "q_scale": 1.0, "r_scale": 1.0}
    estimate.meta["noise_identification"] = record
    if not rejected:
        return estimate
    runs = {(0, 0): (ekf.log_likelihood, ekf, estimate)}

    def score(i: int, j: int) -> float:
        if (i, j) not in runs:
            trial = type(ekf)(p)
            found = walk(trial, sequence, p.noise_factor**i, p.noise_factor**j)
            runs[(i, j)] = (trial.log_likelihood, trial, found)
            record["runs"].append([i, j, trial.log_likelihood])
        return runs[(i, j)][0]

    steps = range(-p.noise_steps, p.noise_steps + 1)
    best = (0, 0)
    while True:
        before = best
        best = (best[0], max(steps, key=lambda j: score(best[0], j)))  # the r line at the current q
        best = (max(steps, key=lambda i: score(i, best[1])), best[1])  # the q line at the best r
        if best == before:
            break
    if 2 * (runs[best][0] - runs[(0, 0)][0]) <= chi2_gate(p.noise_confidence, 2):
        best = (0, 0)
    _, chosen, chosen_estimate = runs[best]
    record.update(q_scale=p.noise_factor ** best[0], r_scale=p.noise_factor ** best[1])
    chosen_estimate.meta["noise_identification"] = record
    if chosen is not ekf:
        ekf.__dict__.update(chosen.__dict__)
    return chosen_estimate
