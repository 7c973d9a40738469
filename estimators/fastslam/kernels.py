"""The per-particle measurement update of FastSLAM 1.0 and 2.0 (numba): a loop over particles is inherent
(each particle associates, samples and writes its own copy-on-write map), so it runs compiled.

For particle m with predicted pose x̂ (3,) and predicted pose covariance P (3, 3) (the motion since the last
sampling, :mod:`.filter`), an observation set z (k, 2) with noise R (2, 2) per observation:

Observation model of landmark μ (2,) from pose x (:mod:`slamarena.estimators.models`; compiled: :mod:`slamarena.estimators.kernels`):
    δ = μ − p, q = δᵀδ, r = √q
    h = (r, atan2(δy, δx) − θ),  H_m = [[δx/r, δy/r], [−δy/q, δx/q]] (2, 2),
    H_x = [[−δx/r, −δy/r, 0], [δy/q, −δx/q, −1]] (2, 3)

FastSLAM 1.0 (proposal = motion model): x ~ N(x̂, P); then per observation of a known landmark
    Q = H_m Σ H_mᵀ + R,  ν = z ⊖ h(x, μ),  log w += log N(ν; 0, Q)
    K = Σ H_mᵀ Q⁻¹ (2, 2),  μ ← μ + K ν,  Σ ← (I − K H_m) Σ (I − K H_m)ᵀ + K R Kᵀ

FastSLAM 2.0 (proposal conditioned on the observations, Montemerlo et al. 2003): starting from
x̄ = x̂, Σx = P, for each observation of a known landmark, linearised at the current x̄:
    Q = H_m Σ H_mᵀ + R,  L = H_x Σx H_xᵀ + Q,  ν = z ⊖ h(x̄, μ),  log w += log N(ν; 0, L)
    Kx = Σx H_xᵀ L⁻¹ (3, 2),  x̄ ← x̄ + Kx ν,  Σx ← (I − Kx H_x) Σx (I − Kx H_x)ᵀ + Kx Q Kxᵀ
then x ~ N(x̄, Σx) and the landmarks are updated at the sampled x as in 1.0 (without weight).
The product of the L-likelihoods is the proposal's normaliser p(z | x̂, map) taken one observation
at a time, each conditioned on the ones before it.

New landmark (both): μ = p + r (cos(θ+b), sin(θ+b)), Σ = G_z R G_zᵀ with G_z = [[c, −r s], [s, r c]].

Unknown association (per particle, maximum likelihood): every live landmark not yet taken in this set is a
candidate if its d² = νᵀ S⁻¹ ν ≤ ``gate`` (S = Q for 1.0 at the sampled pose, L for 2.0 at x̄); the
candidate of largest log N(ν; 0, S) is the match. Without a candidate the observation starts a new
landmark and the weight takes the new-landmark likelihood ``log_p0`` of that row, the sensor density at the gate
under the row's own noise, log p₀_j = −γ/2 − ½ log det R_j − log 2π. With a stated perceptual field
(max range, field of view) each landmark keeps an existence counter (slot state = counter + 1): +1 when
matched, −1 when predicted inside the field from the sampled pose and not matched, removed at −1;
new landmarks start at counter 1.

Heavy-tailed sensor (``huber_k`` = k < ∞): every matched row's log-likelihood takes Huber's ρ_k of d = √(νᵀ S⁻¹ ν)
for d²/2 (the same inside k, linear in d beyond), and a row with d > k is applied with its noise inflated by
1/w = d / k (Q in the 2.0 proposal's K_x step, R in the landmark's EKF). The gate and ``log_p0`` are the caller's
(:func:`.filter.huber_gate`: the Huber density's quantile). k = ∞: the Gaussian model above.

Association at the predicted pose (2.0, ``assoc_predicted``): the candidates are gated and ranked at (x̂, P) for every
row; the chosen landmark is then weighed and conditions the proposal at (x̄, Σx), as with known association.

Tentative landmarks (unknown association, ``confirm`` = k > 1 sightings within ``window`` seconds): a
landmark started at time t₀ is tentative while it has fewer than k sightings (the starting one included).
It is a candidate of the association like any other and its EKF is updated when matched, but the row
takes the new-landmark likelihood ``log_p0`` — as if it started a landmark — and does not condition the
2.0 proposal: until confirmed, a landmark is no evidence about the path. One still tentative after the set
at time t with t − t₀ > window is removed. k = 1: every landmark is confirmed when started (the plain
per-particle maximum likelihood above).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernels import range_bearing, wrap
from .storage import find, writable

__all__ = ["update_particles", "predictive_d2", "sqrt_psd"]

_LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True)
def _mm(A, B):
    """A B for a small matrix A and a small matrix or vector B, as plain loops (numba's matrix product
    calls BLAS, whose call overhead dominates at 2 × 2 and 3 × 3)."""
    if B.ndim == 1:
        v = np.zeros(A.shape[0])
        for i in range(A.shape[0]):
            for k in range(A.shape[1]):
                v[i] += A[i, k] * B[k]
        return v
    out = np.zeros((A.shape[0], B.shape[1]))
    for i in range(A.shape[0]):
        for k in range(A.shape[1]):
            a = A[i, k]
            for j in range(B.shape[1]):
                out[i, j] += a * B[k, j]
    return out


@njit(cache=True)
def _sandwich(A, S):
    """A S Aᵀ."""
    return _mm(_mm(A, S), A.T)


@njit(cache=True)
def _quad(v, S):
    """vᵀ S v."""
    return np.dot(v, _mm(S, v))


@njit(cache=True)
def sqrt_psd(P):
    """A square root A of a symmetric positive semi-definite P (A Aᵀ = P), by eigen-decomposition
    (P may be singular: the motion noise of a twist is rank 2 in the pose)."""
    w, V = np.linalg.eigh(0.5 * (P + P.T))
    A = np.empty_like(P)
    for j in range(P.shape[0]):
        s = math.sqrt(w[j]) if w[j] > 0.0 else 0.0
        for i in range(P.shape[0]):
            A[i, j] = V[i, j] * s
    return A


@njit(cache=True)
def _inv2(S):
    det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    out = np.empty((2, 2))
    out[0, 0] = S[1, 1] / det
    out[1, 1] = S[0, 0] / det
    out[0, 1] = -S[0, 1] / det
    out[1, 0] = -S[1, 0] / det
    return out, det


@njit(cache=True)
def huber_rho(d2, k):
    """Huber's ρ of the whitened innovation size d = √d²: d²/2 for d ≤ k, k d − k²/2 beyond (k = ∞: d²/2, the
    Gaussian). −ρ replaces −d²/2 in a row's log-likelihood, so inliers weigh as under the Gaussian and an outlier's
    log-likelihood falls linearly in d, not quadratically."""
    if d2 <= k * k:
        return 0.5 * d2
    return k * math.sqrt(d2) - 0.5 * k * k


@njit(cache=True)
def huber_scale(d2, k):
    """1 / w of Huber's iteratively reweighted least squares, w = min(1, k / d): the factor by which a row's noise
    is inflated in a Gaussian step so that the step's influence is Huber's (1 for an inlier)."""
    return 1.0 if d2 <= k * k else math.sqrt(d2) / k


@njit(cache=True)
def _landmark_update(x, mu, S, z, R, k, out_mu, out_S):
    """The 2 × 2 EKF of one landmark at pose x (Joseph form), the row's noise R inflated by Huber's 1 / w for a row
    beyond k (k = ∞: the plain EKF); returns the innovation's d² under the stated R."""
    zhat = np.empty(2)
    Hx = np.empty((2, 3))
    Hm = np.empty((2, 2))
    range_bearing(x, mu, zhat, Hx, Hm)
    Sig = np.array([[S[0], S[1]], [S[1], S[2]]])
    Q = _sandwich(Hm, Sig) + R
    Qi, det = _inv2(Q)
    nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
    d2 = _quad(nu, Qi)
    c = huber_scale(d2, k)
    if c > 1.0:
        R = R * c
        Qi, det = _inv2(_sandwich(Hm, Sig) + R)
    K = _mm(_mm(Sig, Hm.T), Qi)
    new_mu = mu + _mm(K, nu)
    A = np.eye(2) - _mm(K, Hm)
    new_S = _sandwich(A, Sig) + _sandwich(K, R)
    out_mu[0] = new_mu[0]
    out_mu[1] = new_mu[1]
    out_S[0] = new_S[0, 0]
    out_S[1] = 0.5 * (new_S[0, 1] + new_S[1, 0])
    out_S[2] = new_S[1, 1]
    return d2


@njit(cache=True)
def _new_landmark(x, z, R, out_mu, out_S):
    a = x[2] + z[1]
    c = math.cos(a)
    s = math.sin(a)
    out_mu[0] = x[0] + z[0] * c
    out_mu[1] = x[1] + z[0] * s
    G = np.array([[c, -z[0] * s], [s, z[0] * c]])
    Sig = _sandwich(G, R)
    out_S[0] = Sig[0, 0]
    out_S[1] = 0.5 * (Sig[0, 1] + Sig[1, 0])
    out_S[2] = Sig[1, 1]


@njit(cache=True)
def _predictive(xbar, Sx, mu, S, z, R, use_pose):
    """Innovation ν, its covariance (L with the pose's uncertainty when ``use_pose``, else Q), H_x, Q."""
    zhat = np.empty(2)
    Hx = np.empty((2, 3))
    Hm = np.empty((2, 2))
    range_bearing(xbar, mu, zhat, Hx, Hm)
    Sig = np.array([[S[0], S[1]], [S[1], S[2]]])
    Q = _sandwich(Hm, Sig) + R
    L = _sandwich(Hx, Sx) + Q if use_pose else Q.copy()
    nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
    return nu, L, Hx, Q


@njit(cache=True)
def predictive_d2(xhat, P, z, slots, n_slots, R, depth, roots, inner_child, leaf_mu, leaf_S):
    """d² (M, k) of every labelled observation z[j] of slot slots[j] in every particle at its predicted pose:
    ν = z ⊖ h(x̂_m, μ), L = H_x P_m H_xᵀ + H_m Σ H_mᵀ + R_j (the 2.0 proposal's first L), d² = νᵀ L⁻¹ ν;
    NaN where the particle has not mapped the slot."""
    M, k = xhat.shape[0], z.shape[0]
    d2 = np.full((M, k), np.nan)
    for m in range(M):
        for j in range(k):
            if slots[j] < n_slots[m]:
                leaf, off = find(roots[m], slots[j], depth, inner_child)
                if leaf >= 0:
                    nu, L, _, _ = _predictive(xhat[m], P[m], leaf_mu[leaf, off], leaf_S[leaf, off], z[j], R[j], True)
                    Li, _ = _inv2(L)
                    d2[m, j] = _quad(nu, Li)
    return d2


@njit(cache=True)
def update_particles(
    version,
    known,
    xhat,
    P,
    eps,
    log_w,
    z,
    slots,
    n_slots,
    n_live,
    R,
    gate,
    log_p0,
    huber_k,
    assoc_predicted,
    max_range,
    half_fov,
    confirm,
    window,
    t,
    depth,
    roots,
    inner_child,
    inner_ref,
    leaf_mu,
    leaf_S,
    leaf_state,
    leaf_seen,
    leaf_born,
    leaf_ref,
    free_inner,
    top_inner,
    used_inner,
    free_leaf,
    top_leaf,
    used_leaf,
    poses_out,
    assoc_out,
):
    """One observation set z (k, 2) for every particle (module docstring).

    known: slots (k,) are the landmarks' slots (the same in every particle; a slot ≥ n_slots[m] is new).
    Otherwise slots are ignored and each particle associates by maximum likelihood; n_slots (M,) grows.
    n_live (M,): each particle's live landmarks, kept up to date (new +1, removed −1).
    xhat (M, 3), P (M, 3, 3): predicted poses and their covariances; eps (M, 3) standard normals.
    R (k, 2, 2): each observation's noise (the same for all, or range dependent). log_p0 (k,): each
    row's new-landmark log-likelihood −γ/2 − ½ log det R_j − log 2π, added to a particle's weight when the row starts a
    landmark (or sights a tentative one).
    Writes the sampled poses to poses_out (M, 3) and each observation's slot to assoc_out (M, k)
    (−1: not used). max_range ≤ 0 disables the existence counters. confirm, window: the tentative-landmark
    rule (unknown association only; confirm = 1: none); t: the time of the set [s] (a new landmark's birth).
    """
    M = xhat.shape[0]
    k = z.shape[0]
    zhat = np.empty(2)
    Hx = np.empty((2, 3))
    Hm = np.empty((2, 2))
    for m in range(M):
        n = n_slots[m]
        # unknown association reads the particle's whole map; known association touches only the
        # observed slots' paths (no scratch of size n: a step is O(k log n) per particle)
        scratch = 0 if known else n
        mus = np.zeros((scratch, 2))
        Ss = np.zeros((scratch, 3))
        states = np.zeros(scratch, dtype=np.int64)
        seens = np.zeros(scratch, dtype=np.int64)
        borns = np.zeros(scratch)
        taken = np.zeros(scratch, dtype=np.bool_)
        if not known:
            for s in range(n):
                leaf, off = find(roots[m], s, depth, inner_child)
                if leaf >= 0:
                    mus[s] = leaf_mu[leaf, off]
                    Ss[s] = leaf_S[leaf, off]
                    states[s] = leaf_state[leaf, off]
                    seens[s] = leaf_seen[leaf, off]
                    borns[s] = leaf_born[leaf, off]
        target = np.full(k, -1, dtype=np.int64)  # slot matched (≥ 0) or −1: new
        xbar = xhat[m].copy()
        Sx = P[m].copy()
        if version == 1:  # the motion model is the proposal: sample first
            xbar = xbar + _mm(sqrt_psd(Sx), eps[m])
            Sx[:, :] = 0.0
        for j in range(k):
            best = -1
            best_ll = -np.inf
            best_nu = np.zeros(2)
            best_L = np.eye(2)
            best_Hx = np.zeros((2, 3))
            best_Q = np.eye(2)
            best_d2 = 0.0
            if known:
                s = slots[j]
                if s < n:
                    leaf, off = find(roots[m], s, depth, inner_child)
                    nu, L, H, Q = _predictive(xbar, Sx, leaf_mu[leaf, off], leaf_S[leaf, off], z[j], R[j], version == 2)
                    Li, det = _inv2(L)
                    best, best_nu, best_L, best_Hx, best_Q = s, nu, L, H, Q
                    best_d2 = _quad(nu, Li)
                    best_ll = -huber_rho(best_d2, huber_k) - 0.5 * math.log(det) - _LOG_2PI
            else:
                # candidates at the proposal so far (x̄, Σx), or (2.0, assoc_predicted) at the predicted pose (x̂, P): then
                # every row's association is independent of the order of the rows and of the conditioning on the others
                at_prediction = assoc_predicted and version == 2
                ax = xhat[m] if at_prediction else xbar
                aS = P[m] if at_prediction else Sx
                for s in range(n):
                    if states[s] == 0 or taken[s]:
                        continue
                    nu, L, H, Q = _predictive(ax, aS, mus[s], Ss[s], z[j], R[j], version == 2)
                    Li, det = _inv2(L)
                    d2 = _quad(nu, Li)
                    if d2 > gate:
                        continue
                    ll = -huber_rho(d2, huber_k) - 0.5 * math.log(det) - _LOG_2PI
                    if ll > best_ll:
                        best, best_ll, best_d2, best_nu, best_L, best_Hx, best_Q = s, ll, d2, nu, L, H, Q
                if best >= 0 and at_prediction:  # weight and conditioning at the proposal so far, as with known ids
                    best_nu, best_L, best_Hx, best_Q = _predictive(xbar, Sx, mus[best], Ss[best], z[j], R[j], True)
                    Li, det = _inv2(best_L)
                    best_d2 = _quad(best_nu, Li)
                    best_ll = -huber_rho(best_d2, huber_k) - 0.5 * math.log(det) - _LOG_2PI
            if best >= 0 and not known and seens[best] < confirm:  # a tentative landmark: no evidence about the path
                target[j] = best
                taken[best] = True
                log_w[m] += log_p0[j]
            elif best >= 0:
                target[j] = best
                if not known:
                    taken[best] = True
                log_w[m] += best_ll
                # condition the proposal on this observation (an outlier's noise inflated by Huber's 1 / w)
                if version == 2:
                    c = huber_scale(best_d2, huber_k)
                    if c > 1.0:
                        best_Q = best_Q * c
                        best_L = _sandwich(best_Hx, Sx) + best_Q
                    Li, _ = _inv2(best_L)
                    Kx = _mm(_mm(Sx, best_Hx.T), Li)
                    xbar = xbar + _mm(Kx, best_nu)
                    A = np.eye(3) - _mm(Kx, best_Hx)
                    Sx = _sandwich(A, Sx) + _sandwich(Kx, best_Q)
            elif not known:
                log_w[m] += log_p0[j]
        x = xbar + _mm(sqrt_psd(Sx), eps[m]) if version == 2 else xbar
        x[2] = wrap(x[2])
        poses_out[m] = x
        # landmark updates at the sampled pose
        new_mu = np.empty(2)
        new_S = np.empty(3)
        for j in range(k):
            s = target[j]
            if s >= 0:
                leaf, off = find(roots[m], s, depth, inner_child)
                _landmark_update(
                    x, leaf_mu[leaf, off].copy(), leaf_S[leaf, off].copy(), z[j], R[j], huber_k, new_mu, new_S
                )
                state = leaf_state[leaf, off] + 1
                seen = leaf_seen[leaf, off] + 1
                born = leaf_born[leaf, off]
            else:
                s = slots[j] if known else n_slots[m]
                n_live[m] += 1
                if not known:
                    n_slots[m] += 1
                elif s >= n_slots[m]:
                    n_slots[m] = s + 1
                _new_landmark(x, z[j], R[j], new_mu, new_S)
                state = 2 if max_range > 0.0 and not known else 1
                seen = 1
                born = t
            leaf, off = writable(
                m,
                s,
                depth,
                roots,
                inner_child,
                inner_ref,
                leaf_mu,
                leaf_S,
                leaf_state,
                leaf_seen,
                leaf_born,
                leaf_ref,
                free_inner,
                top_inner,
                used_inner,
                free_leaf,
                top_leaf,
                used_leaf,
            )
            leaf_mu[leaf, off] = new_mu
            leaf_S[leaf, off] = new_S
            leaf_state[leaf, off] = state
            leaf_seen[leaf, off] = seen
            leaf_born[leaf, off] = born
            assoc_out[m, j] = s
        # the landmarks mapped before this set: negative evidence (live landmarks inside the perceptual field that
        # nothing matched) and expiry (tentative ones past their window)
        if not known and (max_range > 0.0 or confirm > 1):
            for s in range(n):
                if states[s] == 0:
                    continue
                expired = seens[s] + taken[s] < confirm and t - borns[s] > window
                missed = False
                if max_range > 0.0 and not taken[s]:
                    range_bearing(x, mus[s], zhat, Hx, Hm)
                    missed = zhat[0] <= max_range and abs(zhat[1]) <= half_fov
                if expired or missed:
                    leaf, off = writable(
                        m,
                        s,
                        depth,
                        roots,
                        inner_child,
                        inner_ref,
                        leaf_mu,
                        leaf_S,
                        leaf_state,
                        leaf_seen,
                        leaf_born,
                        leaf_ref,
                        free_inner,
                        top_inner,
                        used_inner,
                        free_leaf,
                        top_leaf,
                        used_leaf,
                    )
                    leaf_state[leaf, off] = 0 if expired else leaf_state[leaf, off] - 1
                    if leaf_state[leaf, off] == 0:
                        n_live[m] -= 1
