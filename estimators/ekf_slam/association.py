"""Data association for EKF-SLAM: Mahalanobis nearest neighbour and JCBB.

Both work on the current estimate ``x`` (N,), ``P`` (N, N) with the layout
``[x, y, θ, m0x, m0y, …]`` and an observation set ``z`` (M, 2) = (range, bearing).

Individual compatibility (vectorised over all M × n pairs). For landmark i the Jacobian
``H_i = [H_x,i  H_m,i]`` (2 × 5) does not depend on the observation, so ``H_i P H_iᵀ`` is
computed once per landmark from the robot block, the robot-landmark cross-covariance and the
landmark block — batched 2 × 2 algebra, O(n) — and the observation's noise R_j (2 × 2; it may
depend on the observation, e.g. Cartesian sensor noise) is added per pair::

    S_ji = H_x P_rr H_xᵀ + H_x P_ri H_mᵀ + (H_x P_ri H_mᵀ)ᵀ + H_m P_ii H_mᵀ + R_j    (M, n, 2, 2)
    ν_ji = z_j − h(x_r, m_i)   (bearing wrapped)                                    (M, n, 2)
    d²_ji = ν_jiᵀ S_i⁻¹ ν_ji   (closed-form 2 × 2 inverse)                           (M, n)

Nearest neighbour: observation j pairs with ``i* = argmin_i d²_ji`` when
``d² < χ²₂(match_confidence)``; it starts a new landmark when even the nearest is beyond the
separate new-landmark gate ``χ²₂(new_confidence)``; in between it is rejected (ambiguous).

JCBB (Neira & Tardós 2001): branch and bound over hypotheses that pair each observation
with an individually compatible landmark or with nothing, requiring the whole hypothesis to be
jointly compatible, ``ν_Jᵀ S_J⁻¹ ν_J < χ²_{2k}(confidence)`` with
``S_J = H_J P_sub H_Jᵀ + blockdiag(R_j)`` over the robot and the candidate landmarks (``P_sub`` is
the small dense block of those states), and keeping the hypothesis with the most pairings
(ties: the smaller joint NIS). Unpaired observations then go through the new-landmark gate.

Landmark management (:class:`LandmarkBook`; only for landmarks created from rows without a
trusted id, whose existence the filter itself decided):

* **tentative landmarks**: a landmark created from an unlabelled row is tentative until it has been
  matched ``confirm_sightings − 1`` more times within ``confirm_window`` seconds of its creation; a
  tentative landmark takes part in association and updates like any other (its re-sightings must be
  able to find it), and one not confirmed in time is removed — marginalised out of x and P — so that
  a single spurious or outlying detection leaves no landmark behind;
* **quality counter** (Dissanayake et al. 2001): each managed landmark's quality rises by one per
  match and falls by one per observation set in which it is predicted inside the sensor's field
  (predicted range < ``sensor_range``, |predicted bearing| < ``sensor_fov``/2) and not matched; a
  landmark whose quality falls below ``−miss_limit`` is removed.

The χ² gates use each pair's innovation covariance S (range and bearing jointly, above); rows
between the match and the new-landmark gates are rejected as ambiguous, so an outlier near a mapped
landmark is neither applied nor mapped.

Ambiguity and the look-ahead decision (:func:`hypotheses`; the ``window`` of :class:`~.filter.EKFSLAMParams`, run by
:mod:`.run`). A d² gate does not see how large S is: when the robot's position σ is tens of metres, a single tree is
within the match gate of many mapped trees and of wherever an unmapped one might stand. Each row j has the hypotheses
"landmark i" with the predictive density λ_ji and "a tree not in the map" with the density λ_j0 that a perfectly known
landmark has at the new-landmark gate (the new-landmark likelihood of FastSLAM, p0)::

    log λ_ji = −½ d²_ji − ½ log det S_ji − log 2π          log λ_j0 = −½ χ²₂(new_confidence) − ½ log det R_j − log 2π
    p(i | z_j) = λ_ji / (λ_j0 + Σ_k λ_jk)                    (i = 0: not in the map)

The row is ambiguous when its most probable hypothesis has p < ``match_confidence``. Its hypotheses (the
``window_hypotheses`` most probable landmarks among those inside the match gate, and "not in the map") are then decided
on the evidence of the next ``window`` observation sets: each is applied to a copy of the filter, the copy runs on
through the window with the plain association, and the hypothesis whose copy explains the window best — the largest
log-likelihood Σ log λ of all its rows, a matched row scoring the λ of its landmark, a new or rejected row λ_0 (the
prediction-error decomposition of p(z_window | hypothesis)) — is applied. Unambiguous rows are decided as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numba import njit
from scipy.linalg import block_diag

from slamarena.datasets.geometry import wrap_angle

from ..kernels import range_bearing, wrap
from ..models import chi2_gate, observation_jacobians, observe
from .checks import CovarianceError

__all__ = [
    "Decision",
    "Association",
    "LandmarkBook",
    "compatibility",
    "innovation_cov",
    "pair_d2",
    "nearest_neighbour",
    "jcbb",
    "log_density",
    "log_densities",
    "hypotheses",
]


class Decision(IntEnum):
    """What is done with an observation (the int8 code of ``Estimate.diagnostics["assoc_decision"]``)."""

    MATCHED = 0  # applied as an observation of a mapped landmark
    NEW = 1  # starts a landmark
    REJECTED = 2  # ambiguous (between the gates) or an outlier of a labelled landmark


@dataclass
class Association:
    """Per observation: decision (:class:`Decision`), landmark slot (−1 if none), d² to the nearest."""

    decision: np.ndarray
    slot: np.ndarray
    d2: np.ndarray


def innovation_cov(x: np.ndarray, P: np.ndarray, slots: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Predicted observations (k, 2) and H P Hᵀ (k, 2, 2) of landmark slots (k,), O(k)."""
    xr = x[:3]
    base = 3 + 2 * slots
    L = np.column_stack([x[base], x[base + 1]])
    Hx, Hm = observation_jacobians(xr, L)
    Pri = np.stack([P[:3, base], P[:3, base + 1]], axis=-1).transpose(1, 0, 2)  # (k, 3, 2)
    rows = base[:, None, None] + np.arange(2)[None, :, None]
    Pii = P[rows, rows.transpose(0, 2, 1)]  # (k, 2, 2)
    cross = Hx @ Pri @ Hm.transpose(0, 2, 1)
    return observe(xr, L), Hx @ P[:3, :3] @ Hx.transpose(0, 2, 1) + cross + cross.transpose(
        0, 2, 1
    ) + Hm @ Pii @ Hm.transpose(0, 2, 1)


def _mahalanobis(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """νᵀ S⁻¹ ν with the closed-form 2 × 2 inverse, broadcast over leading axes; checks S is PD."""
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    det = a * d - b * c
    if not np.all((det > 0) & (a > 0)):
        raise CovarianceError("an innovation covariance is not positive definite")
    n0, n1 = nu[..., 0], nu[..., 1]
    with np.errstate(over="ignore", invalid="ignore"):  # an absurd innovation gives d² = ∞ or NaN, inside no gate
        return (d * n0 * n0 - (b + c) * n0 * n1 + a * n1 * n1) / det


def compatibility(
    x: np.ndarray, P: np.ndarray, R: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Innovations ν (M, n, 2), covariances S (M, n, 2, 2) and Mahalanobis d² (M, n); R (M, 2, 2) per observation."""
    n = (x.shape[0] - 3) // 2
    M = z.shape[0]
    if n == 0:
        return np.zeros((M, 0, 2)), np.zeros((M, 0, 2, 2)), np.zeros((M, 0))
    zhat, HPHt = innovation_cov(x, P, np.arange(n))
    S = HPHt[None] + R[:, None]
    nu = z[:, None, :] - zhat[None, :, :]
    nu[..., 1] = wrap_angle(nu[..., 1])
    return nu, S, _mahalanobis(nu, S)


def pair_d2(x: np.ndarray, P: np.ndarray, R: np.ndarray, z: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """Mahalanobis d² (k,) of observation z[j] (k, 2) with noise R[j] (k, 2, 2) against landmark slots[j] — the formulas
    of the compatibility test for k given pairs, one compiled loop (:func:`_pair_d2`)."""
    if slots.size == 0:
        return np.zeros(0)
    d2, ok = _pair_d2(
        x,
        P,
        np.ascontiguousarray(slots, dtype=np.int64),
        np.ascontiguousarray(z, dtype=float),
        np.ascontiguousarray(R, dtype=float),
    )
    if not ok:
        raise CovarianceError("an innovation covariance is not positive definite")
    return d2


@njit(cache=True)
def _pair_d2(x, P, slots, z, R):
    """d² of each pair from the robot block, the robot rows and the landmark's 2 × 2 block of P; whether every S is PD."""
    k = slots.size
    d2 = np.empty(k)
    zhat, Hx, Hm = np.empty(2), np.empty((2, 3)), np.empty((2, 2))
    H = np.empty((2, 5))
    idx = np.empty(5, dtype=np.int64)
    idx[:3] = np.arange(3)
    for j in range(k):
        e = 3 + 2 * slots[j]
        idx[3], idx[4] = e, e + 1
        range_bearing(x[:3], x[e : e + 2], zhat, Hx, Hm)
        H[:, :3], H[:, 3:] = Hx, Hm
        S = R[j].copy()
        for a in range(2):
            for b in range(2):
                acc = 0.0
                for c in range(5):
                    for d in range(5):
                        acc += H[a, c] * P[idx[c], idx[d]] * H[b, d]
                S[a, b] += acc
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        if not (det > 0.0 and S[0, 0] > 0.0):
            return d2, False
        n0, n1 = z[j, 0] - zhat[0], wrap(z[j, 1] - zhat[1])
        d2[j] = (S[1, 1] * n0 * n0 - (S[0, 1] + S[1, 0]) * n0 * n1 + S[0, 0] * n1 * n1) / det
    return d2, True


def log_density(S: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """log N(ν; 0, S) = −½ d² − ½ log |S| − log 2π of 2-D innovations ν with covariances S (..., 2, 2) and
    squared Mahalanobis distances d² = νᵀS⁻¹ν (...)."""
    return -0.5 * d2 - 0.5 * np.log(S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]) - np.log(2 * np.pi)


def log_densities(S: np.ndarray, d2: np.ndarray, R: np.ndarray, gate_new: float) -> tuple[np.ndarray, np.ndarray]:
    """log λ (M, n) of each pair (innovation covariances S (M, n, 2, 2), d² (M, n)) and log λ_0 (M,) of "not in the map"
    for rows with noise R (M, 2, 2) (module docstring)."""
    return log_density(S, d2), log_density(R, gate_new)


def hypotheses(
    log_lam: np.ndarray, log_new: np.ndarray, d2: np.ndarray, gate_match: float, confidence: float, limit: int
) -> tuple[int, np.ndarray] | None:
    """The first ambiguous row (module docstring) and its hypotheses — up to ``limit`` landmark slots inside the match gate,
    most probable first, then −1 ("not in the map") — or None if no row is ambiguous."""
    if log_lam.shape[1] == 0:
        return None
    top = np.maximum(log_lam.max(axis=1), log_new)
    lam, new = np.exp(log_lam - top[:, None]), np.exp(log_new - top)
    posterior = lam / (new + lam.sum(axis=1))[:, None]
    ambiguous = np.flatnonzero(np.maximum(posterior.max(axis=1), new / (new + lam.sum(axis=1))) < confidence)
    for j in ambiguous.tolist():
        inside = np.flatnonzero(d2[j] < gate_match)
        if inside.size:
            return j, np.r_[inside[np.argsort(-posterior[j, inside])][:limit], -1]
    return None


def _gate_unpaired(d2_min: np.ndarray, gate_new: float) -> np.ndarray:
    return np.where(d2_min >= gate_new, Decision.NEW, Decision.REJECTED)


def nearest_neighbour(d2: np.ndarray, gate_match: float, gate_new: float) -> Association:
    """Mahalanobis nearest neighbour with a match gate and a separate new-landmark gate."""
    M, n = d2.shape
    if n == 0:
        return Association(np.full(M, Decision.NEW, dtype=np.int8), np.full(M, -1), np.full(M, np.inf))
    best = np.argmin(d2, axis=1)
    d2_min = d2[np.arange(M), best]
    matched = d2_min < gate_match
    decision = np.where(matched, Decision.MATCHED, _gate_unpaired(d2_min, gate_new)).astype(np.int8)
    return Association(decision, np.where(matched, best, -1), d2_min)


def jcbb(
    x: np.ndarray,
    P: np.ndarray,
    R: np.ndarray,
    z: np.ndarray,
    d2: np.ndarray,
    nu: np.ndarray,
    gate_match: float,
    gate_new: float,
    confidence: float,
) -> Association:
    """Joint compatibility branch and bound (see the module docstring)."""
    M, n = d2.shape
    if n == 0:
        return nearest_neighbour(d2, gate_match, gate_new)
    candidates = [np.flatnonzero(d2[j] < gate_match) for j in range(M)]
    candidates = [c[np.argsort(d2[j, c])] for j, c in enumerate(candidates)]
    union = np.unique(np.concatenate(candidates)) if any(c.size for c in candidates) else np.zeros(0, dtype=int)
    d2_min = d2.min(axis=1)
    if union.size == 0:
        return Association(_gate_unpaired(d2_min, gate_new).astype(np.int8), np.full(M, -1), d2_min)
    # dense block of the robot and the candidate landmarks; Jacobians in that sub-state
    local = {int(s): k for k, s in enumerate(union)}
    sub = np.r_[0:3, np.ravel(3 + 2 * union[:, None] + np.arange(2))]
    C = P[np.ix_(sub, sub)]
    Hx, Hm = observation_jacobians(x[:3], x[3:].reshape(n, 2)[union])
    width = sub.size
    gates = [0.0] + [chi2_gate(confidence, 2 * k) for k in range(1, M + 1)]

    def rows(j: int, s: int) -> np.ndarray:
        H = np.zeros((2, width))
        k = local[s]
        H[:, :3] = Hx[k]
        H[:, 3 + 2 * k : 5 + 2 * k] = Hm[k]
        return H

    def joint_nis(pairs: list[tuple[int, int]]) -> float:
        H = np.vstack([rows(j, s) for j, s in pairs])
        v = np.concatenate([nu[j, s] for j, s in pairs])
        S = H @ C @ H.T + block_diag(*(R[j] for j, _ in pairs))
        return float(v @ np.linalg.solve(S, v))

    best: dict = {"pairs": [], "nis": np.inf}

    def search(j: int, pairs: list[tuple[int, int]], nis: float) -> None:
        if j == M:
            if len(pairs) > len(best["pairs"]) or (len(pairs) == len(best["pairs"]) and nis < best["nis"]):
                best["pairs"], best["nis"] = list(pairs), nis
            return
        used = {s for _, s in pairs}
        for s in candidates[j]:
            s = int(s)
            if s in used:
                continue
            trial = pairs + [(j, s)]
            value = joint_nis(trial)
            if value < gates[len(trial)]:
                search(j + 1, trial, value)
        if len(pairs) + (M - j - 1) > len(best["pairs"]):
            search(j + 1, pairs, nis)

    search(0, [], 0.0)
    slot = np.full(M, -1)
    for j, s in best["pairs"]:
        slot[j] = s
    decision = np.where(slot >= 0, Decision.MATCHED, _gate_unpaired(d2_min, gate_new)).astype(np.int8)
    d2_out = np.where(slot >= 0, d2[np.arange(M), np.maximum(slot, 0)], d2_min)
    return Association(decision, slot, d2_out)


class LandmarkBook:
    """Tentative landmarks and the quality counter, per landmark slot (see the module docstring).

    Per slot: ``managed`` (created from an unlabelled row), ``born`` [s], ``seen`` (sightings, the
    creating one included), ``confirmed``, ``quality`` (matches − predicted-visible misses).
    """

    def __init__(
        self,
        confirm_sightings: int,
        confirm_window: float,
        miss_limit: int | None,
        sensor_range: float | None,
        sensor_fov: float,
    ):
        self.confirm_sightings, self.confirm_window = confirm_sightings, confirm_window
        self.miss_limit, self.sensor_range, self.sensor_fov = miss_limit, sensor_range, sensor_fov
        self.managed = np.zeros(0, dtype=bool)
        self.born = np.zeros(0)
        self.seen = np.zeros(0, dtype=np.int64)
        self.quality = np.zeros(0, dtype=np.int64)
        self.removed = {"unconfirmed": 0, "quality": 0}

    @property
    def confirmed(self) -> np.ndarray:
        return ~self.managed | (self.seen >= self.confirm_sightings)

    def add(self, t: float, managed: bool) -> None:
        """A landmark was appended to the state (its slot is the next one)."""
        self.managed = np.r_[self.managed, managed]
        self.born = np.r_[self.born, t]
        self.seen = np.r_[self.seen, 1]
        self.quality = np.r_[self.quality, 0]

    def observe(self, t: float, matched: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """After a set at time t: ``matched`` slots (k,), ``predicted`` (range, bearing) (n, 2) of every slot before the set
        (landmarks created in the set: NaN; None without the quality counter). Returns the slots to remove (ascending)."""
        counting = self.miss_limit is not None
        if counting:
            with np.errstate(invalid="ignore"):
                visible = (predicted[:, 0] < self.sensor_range) & (np.abs(predicted[:, 1]) < 0.5 * self.sensor_fov)
        else:
            visible = np.zeros(0, dtype=bool)
        remove, unconfirmed, lost = _book_counts(
            self.seen,
            self.quality,
            self.managed,
            self.born,
            np.asarray(matched, dtype=np.int64),
            visible,
            float(t),
            int(self.confirm_sightings),
            float(self.confirm_window),
            int(self.miss_limit) if counting else -1,
            counting,
        )
        self.removed["unconfirmed"] += unconfirmed
        self.removed["quality"] += lost
        return remove

    def remove(self, slots: np.ndarray) -> None:
        keep = np.setdiff1d(np.arange(self.seen.size), slots)
        self.managed, self.born, self.seen, self.quality = (
            a[keep] for a in (self.managed, self.born, self.seen, self.quality)
        )


@njit(cache=True)
def _book_counts(seen, quality, managed, born, matched, visible, t, sightings, window, miss_limit, counting):
    """:meth:`LandmarkBook.observe`'s counting in one pass, in place: ``seen`` += the matches of each slot, ``quality`` +1 per
    matched slot and (``counting``) −1 per ``visible`` slot not matched; returns the managed slots to remove (ascending) —
    unconfirmed (fewer than ``sightings`` since birth, older than ``window``) or lost (quality below −``miss_limit``) — and
    how many of each (a slot both unconfirmed and lost counts as unconfirmed)."""
    n = seen.size
    hit = np.zeros(n, dtype=np.bool_)
    for s in matched:
        seen[s] += 1
        hit[s] = True
    remove = np.empty(n, dtype=np.int64)
    k = unconfirmed = lost = 0
    for s in range(n):
        if hit[s]:
            quality[s] += 1
        elif counting and visible[s]:
            quality[s] -= 1
        if not managed[s]:
            continue
        if seen[s] < sightings and t - born[s] > window:
            unconfirmed += 1
        elif counting and quality[s] < -miss_limit:
            lost += 1
        else:
            continue
        remove[k] = s
        k += 1
    return remove[:k], unconfirmed, lost
