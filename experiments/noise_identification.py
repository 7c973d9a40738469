"""Sensor-model identification by the innovation likelihood of EKF-SLAM with the data's landmark ids.

A recording without ground truth (Victoria Park) still says how well a noise model describes it: run the filter with
the known association and score the innovations of the labelled re-observations under their own covariance,

    ℓ(θ) = (1/K) Σ_k log N(ν_k; 0, S_k) = −½ (1/K) Σ_k (ν_kᵀ S_k⁻¹ ν_k + log det S_k + 2 log 2π)        (Mehra 1970)

for a noise model θ (diagonal entries of covariance parameters of :class:`EKFSLAMParams`, e.g. the tree noise σ² and the
odometry increment variances). ν_k (2,) and S_k (2 × 2) are each labelled row's innovation and innovation covariance
against the estimate before its observation set (:func:`slamarena.estimators.ekf_slam.association.compatibility`; the
rows of one set after the first are scored before, not after, the set's earlier updates: exact for single-row sets).

:func:`identify` maximises ℓ over a geometric grid of each identified entry (the stated value times ``step``ᵏ) by
coordinate ascent from the stated model: each entry in turn moves one grid step up or down while ℓ increases, until no
move improves it (every model evaluated is returned, in order). The result is a model stated once in a config, as the
MRCLAM noise is identified against Vicon: it uses the evaluation data and the ids, never the runs without ids.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.association import compatibility, log_density

__all__ = ["InnovationScore", "Identification", "innovation_score", "identify"]


@dataclass(frozen=True)
class InnovationScore:
    """ℓ (the mean log-likelihood per labelled row), the mean NIS per dof, the fraction beyond χ²₂(0.95) = 5.99, rows scored."""

    loglik: float
    nis_per_dof: float
    beyond_95: float
    rows: int


class _Scoring(EKFSLAM):
    """EKF-SLAM that records, before each observation set, ν and S of its labelled rows of mapped landmarks."""

    def reset(self, sequence=None) -> None:
        super().reset(sequence)
        self.scored: list[tuple[float, float]] = []  # (d², log N(ν; 0, S)) per labelled re-observation

    def update(
        self, z, t: float | None = None, decide: dict[int, int] | None = None, R: np.ndarray | None = None
    ) -> None:
        rows = np.asarray(z, dtype=float).reshape(-1, 3)
        ok = np.all(np.isfinite(rows), axis=1) & (rows[:, 0] >= 0) & np.isin(rows[:, 2], self.landmark_ids)
        if ok.any():
            mapped = rows[ok]
            where = {int(i): k for k, i in enumerate(self.landmark_ids)}
            slot = np.array([where[int(i)] for i in mapped[:, 2]])
            Rz = self.observation_cov(mapped) if R is None else np.asarray(R, dtype=float)[ok]
            _, S, d2 = compatibility(self.x, self.P, Rz, mapped[:, :2])
            pick = np.arange(len(mapped))
            self.scored.extend(zip(d2[pick, slot].tolist(), log_density(S[pick, slot], d2[pick, slot]).tolist()))
        super().update(z, t, decide, R)


def innovation_score(sequence, params: dict) -> InnovationScore:
    """Run EKF-SLAM with ``params`` (``use_ids`` forced on) on ``sequence`` and score its labelled innovations."""
    ekf = _Scoring(**{**params, "use_ids": True})
    ekf.run(sequence)
    if not ekf.scored:
        raise ValueError("no labelled re-observation to score: the sequence needs landmark ids seen more than once")
    d2, loglik = np.array(ekf.scored).T
    return InnovationScore(
        float(loglik.mean()), float(d2.mean() / 2.0), float(np.mean(d2 > 5.991464547107979)), int(d2.size)
    )


@dataclass
class Identification:
    """The identified model (parameter name → covariance matrix), its score, and every (model, score) evaluated, in order."""

    model: dict[str, np.ndarray]
    score: InnovationScore
    exponents: dict[tuple[str, int], int]
    trace: list[tuple[dict[tuple[str, int], int], InnovationScore]] = field(default_factory=list)


def identify(
    sequence,
    params: dict,
    stated: dict[str, np.ndarray],
    entries: dict[str, list[int]],
    step: float = 4.0,
    max_exponent: int = 6,
) -> Identification:
    """Coordinate ascent of ℓ over ``stated[name][i, i] · step**k`` (|k| ≤ max_exponent) for each ``i in entries[name]``.

    ``params``: the filter's other parameters; ``stated``: each identified covariance parameter's stated (diagonal)
    matrix; ``entries``: which of its diagonal entries are identified (the others keep their stated value).
    """
    coords = [(name, i) for name, idx in entries.items() for i in idx]
    for name, i in coords:
        if np.count_nonzero(stated[name] - np.diag(np.diag(stated[name]))):
            raise ValueError(f"{name}: only diagonal covariances are identified")
    cache: dict[tuple[int, ...], InnovationScore] = {}
    trace: list = []

    def model_of(k: dict) -> dict[str, np.ndarray]:
        out = {name: np.array(m, dtype=float) for name, m in stated.items()}
        for (name, i), e in k.items():
            out[name][i, i] *= step**e
        return out

    def score(k: dict) -> InnovationScore:
        key = tuple(k[c] for c in coords)
        if key not in cache:
            cache[key] = innovation_score(sequence, {**params, **{n: m.tolist() for n, m in model_of(k).items()}})
            trace.append((dict(k), cache[key]))
        return cache[key]

    best = {c: 0 for c in coords}
    improved = True
    while improved:
        improved = False
        for c in coords:
            for direction in (-1, 1):
                while abs(best[c] + direction) <= max_exponent:
                    trial = {**best, c: best[c] + direction}
                    if score(trial).loglik <= score(best).loglik:
                        break
                    best, improved = trial, True
    return Identification(model_of(best), score(best), best, trace)
