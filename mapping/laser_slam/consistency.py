"""Pairwise consistency of loop closures (PCM, Mangelson et al., ICRA 2018): which loops agree with each other through
the odometry chain, and the largest set that agrees as a whole.

Poses are SE(2) (x, y, θ) with GTSAM's right perturbation: a noisy relative pose is T̂ Exp(ε), ε ~ N(0, C) in T's end
frame (where BetweenFactorPose2 measures its error). Ad_T (3, 3) is Pose2's adjoint, [[R(θ), (y, −x)ᵀ], [0, 0, 1]],
with T Exp(ε) = Exp(Ad_T ε) T.

Odometry chain. The graph's sequential factors z_i (node i − 1 → i, covariance Σ_i) compose to the front-end poses L_i.
The chain's relative pose from node p to node q is T_pq = L_p⁻¹ L_q, and moving every factor's noise to its end gives

    Cov(T_pq) = Ad_{L_q⁻¹} |S_q − S_p| Ad_{L_q⁻¹}ᵀ,    S_k = Σ_{i ≤ k} Ad_{L_i} Σ_i Ad_{L_i}ᵀ   (3, 3)

in q's frame, for q after p and (by the inverse's rule, Cov(T⁻¹) = Ad_T Cov(T) Ad_Tᵀ in the other end's frame) for
q before p alike: one prefix sum S makes any segment's covariance O(1).

Pairwise test. A loop l = (a, n, z, Σ) claims X_a⁻¹ X_n = z. Two loops l_i, l_j and the chain close a cycle

    E = z_i⁻¹ · T_{a_i a_j} · z_j · T_{n_j n_i}  (= identity when both loops and the chain are right),

whose error e = Log(E) (3,) has, to first order, the covariance Σ_E = Σ_m Ad_{P_m⁻¹} C_m Ad_{P_m⁻¹}ᵀ over the four
factors A_m with covariance C_m in their end frames (z_i⁻¹'s: Ad_{z_i} Σ_i Ad_{z_i}ᵀ) and P_m the product of the factors
after A_m. The pair is consistent when d² = eᵀ Σ_E⁻¹ e ≤ the χ²₃ quantile ``threshold``. The segments of the chain
are treated as independent of each other, as in PCM.

Largest consistent set. The loops are the vertices of a graph with an edge for every consistent pair; the loops
accepted are a maximum clique. Finding one is NP-hard; candidates arrive one at a time, so the clique is kept
incrementally (:class:`ConsistentSet`): a new loop consistent with every member joins it (a maximum clique plus a
vertex adjacent to all of it is a maximum clique); otherwise the largest clique containing the new loop is grown
greedily (Pattabiraman et al. 2015's heuristic: repeatedly add the candidate with most neighbours among the
remaining candidates) and replaces the current one when it is larger. Loops outside the clique are rejected (and can
come back when a later clique contains them).
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.geometry import between, compose, inverse, se2_log

__all__ = ["ConsistentSet", "OdometryChain", "adjoint", "cycle_mahalanobis", "greedy_clique"]


def adjoint(T: np.ndarray) -> np.ndarray:
    """Pose2's adjoint Ad_T (…, 3, 3) of poses T (…, 3): T Exp(ε) = Exp(Ad_T ε) T."""
    T = np.asarray(T, dtype=float)
    c, s = np.cos(T[..., 2]), np.sin(T[..., 2])
    out = np.zeros(T.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = c, -s, T[..., 1]
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = s, c, -T[..., 0]
    out[..., 2, 2] = 1.0
    return out


def _sandwich(A: np.ndarray, C: np.ndarray) -> np.ndarray:
    return A @ C @ np.swapaxes(A, -1, -2)


class OdometryChain:
    """The front-end poses L_i (N, 3) and the prefix sums S_i (N, 3, 3) of the module docstring."""

    def __init__(self):
        self.L = np.zeros((0, 3))
        self.S = np.zeros((0, 3, 3))

    def add(self, pose: np.ndarray, cov: np.ndarray | None) -> None:
        """Node i at front-end pose L_i, reached from node i − 1 by a factor of covariance ``cov`` (None for node 0)."""
        pose = np.asarray(pose, dtype=float).reshape(1, 3)
        term = np.zeros((3, 3)) if cov is None else _sandwich(adjoint(pose[0]), np.asarray(cov, dtype=float))
        last = self.S[-1] if len(self.S) else np.zeros((3, 3))
        self.L = np.vstack([self.L, pose])
        self.S = np.concatenate([self.S, (last + term)[None]])

    def relative(self, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The chain's T_pq (…, 3) and its covariance (…, 3, 3) in q's frame, for node indices p, q (…)."""
        p, q = np.asarray(p), np.asarray(q)
        T = between(self.L[p], self.L[q])
        lo, hi = np.minimum(p, q), np.maximum(p, q)
        return T, _sandwich(adjoint(inverse(self.L[q])), self.S[hi] - self.S[lo])


def cycle_mahalanobis(chain: OdometryChain, a_i, n_i, z_i, cov_i, a_j, n_j, z_j, cov_j) -> np.ndarray:
    """d² (m,) of the cycles z_i⁻¹ · T_{a_i a_j} · z_j · T_{n_j n_i} of m loop pairs (module docstring); node indices
    (m,), relative poses (m, 3), covariances (m, 3, 3) (broadcast)."""
    z_i, z_j = np.asarray(z_i, dtype=float), np.asarray(z_j, dtype=float)
    T_a, C_a = chain.relative(a_i, a_j)
    T_n, C_n = chain.relative(n_j, n_i)
    factors = [inverse(z_i), T_a, z_j, T_n]
    covs = [_sandwich(adjoint(z_i), np.asarray(cov_i, dtype=float)), C_a, np.asarray(cov_j, dtype=float), C_n]
    shape = np.broadcast_shapes(*(f.shape for f in factors))
    after = np.zeros(shape)  # P_m: the product of the factors after A_m, from the last one back
    cov = np.zeros(shape + (3,))
    for f, c in zip(factors[::-1], covs[::-1]):
        cov = cov + _sandwich(adjoint(inverse(after)), c)
        after = compose(f, after)
    e = se2_log(after)
    return np.einsum("...i,...i->...", e, np.linalg.solve(cov, e[..., None])[..., 0])


def greedy_clique(adjacent: np.ndarray, seed: int) -> np.ndarray:
    """A clique (sorted vertex indices) containing ``seed`` of the graph with boolean adjacency (m, m), grown by adding
    the candidate with most neighbours among the remaining candidates."""
    members = [seed]
    candidates = adjacent[seed].copy()
    candidates[seed] = False
    while candidates.any():
        idx = np.flatnonzero(candidates)
        u = idx[np.argmax(adjacent[np.ix_(idx, idx)].sum(axis=1))]
        members.append(int(u))
        candidates &= adjacent[u]
        candidates[u] = False
    return np.sort(np.asarray(members, dtype=np.int64))


class ConsistentSet:
    """Loops arriving one at a time, their pairwise consistency, and the current maximum consistent set (module
    docstring). ``threshold``: the χ²₃ quantile of the pairwise test."""

    def __init__(self, chain: OdometryChain, threshold: float):
        self.chain = chain
        self.threshold = threshold
        self.a = np.zeros(0, dtype=np.int64)
        self.n = np.zeros(0, dtype=np.int64)
        self.z = np.zeros((0, 3))
        self.cov = np.zeros((0, 3, 3))
        self.adjacent = np.zeros((0, 0), dtype=bool)
        self.clique = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.a)

    def add(self, a: int, n: int, z: np.ndarray, cov: np.ndarray) -> np.ndarray:
        """Loop (a, n, z, Σ) as the next vertex; returns the maximum consistent set afterwards (vertex indices)."""
        m = len(self.a)
        row = np.zeros(m + 1, dtype=bool)
        row[m] = True
        if m:
            d2 = cycle_mahalanobis(self.chain, a, n, z, cov, self.a, self.n, self.z, self.cov)
            row[:m] = d2 <= self.threshold
        self.a, self.n = np.append(self.a, a), np.append(self.n, n)
        self.z, self.cov = np.vstack([self.z, z]), np.concatenate([self.cov, np.asarray(cov)[None]])
        adjacent = np.zeros((m + 1, m + 1), dtype=bool)
        adjacent[:m, :m], adjacent[m], adjacent[:, m] = self.adjacent, row, row
        self.adjacent = adjacent
        if row[self.clique].all():
            self.clique = np.append(self.clique, m)
        else:
            grown = greedy_clique(adjacent, m)
            if len(grown) > len(self.clique):
                self.clique = grown
        return self.clique
