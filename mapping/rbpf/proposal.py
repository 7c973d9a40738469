"""The improved proposal (Grisetti, Stachniss & Burgard 2007) on the particles' tiled maps.

Target of particle i at a filter step (pose ξ ∈ ℝ³, scan end points s_n (N, 2) in the robot frame):

    τ_i(ξ) = p(z | m_i, ξ) · N(ξ; ĝ_i, Σ_u)                                              (scalar)

* scan likelihood  ``p(z | m, ξ) = exp(−Σ_n r_n(ξ)² / 2σ_z²)``, ``r_n = 1 − M(R(ψ) s_n + t)`` with M the
  bilinearly interpolated occupancy probability of the particle's map (the Gauss-Newton matcher's residual,
  :mod:`slamarena.mapping.scan_matching.gauss_newton`; cells never observed have M = 0.5);
* motion model  ``N(ξ; ĝ_i, Σ_u)``: ĝ_i the particle's pose moved by the odometry, Σ_u (3, 3) from the
  odometry motion since the last filter step (the same for every particle).

**Mode.** Gauss-Newton on −log τ, coarse to fine over the map pyramid: with ``J_n = ∇M ∂S_n/∂ξ`` (1, 3),
``H = Σ J_nᵀ J_n`` (3, 3), ``g = Σ J_nᵀ r_n`` (3,) and ``Λ = Σ_u⁻¹``,

    A = H / σ_z² + Λ                    Δξ = A⁻¹ (g / σ_z² + Λ (ĝ − ξ))                   (3, 3), (3,)

(the matcher's step with the motion model as its prior), giving the mode ξ*_i and ``A_i`` at ξ*_i on the
finest level. With ``halvings`` > 0 (``RBPFParams.step_halvings``) a step that does not lower −log τ is halved up to
that many times and a level stops where none does (a descent; the undamped step settles into a millimetre two-cycle on
the bilinear map's kinks: research/method/rbpf.md).

**K points.** With ``L_i L_iᵀ = A_i⁻¹`` (Laplace covariance) the K = 27 points ``ξ_ij = ξ*_i + L_i u_j`` on the
tensor 3-point Gauss–Hermite rule (``u_j ∈ {−√3, 0, √3}³``, weights ``w_j = Π (1/6, 2/3, 1/6)``, exact for
polynomials of degree ≤ 5 under the standard normal density φ) are evaluated with τ_i. Substituting
``ξ = ξ*_i + L_i u``:

    η_i = ∫ τ_i(ξ) dξ = |L_i| ∫ [τ_i(ξ*_i + L_i u) / φ(u)] φ(u) du ≈ |L_i| Σ_j c_ij,   c_ij = w_j τ_i(ξ_ij) / φ(u_j)
    μ_i = Σ_j c_ij ξ_ij / Σ_j c_ij,     Σ_i = Σ_j c_ij (ξ_ij − μ_i)(ξ_ij − μ_i)ᵀ / Σ_j c_ij         (3,), (3, 3)

(Grisetti 2007, eqs. 13–16, with the points placed and weighted by the rule instead of a fixed lattice:
when τ_i is Gaussian the sums are exact — μ_i = ξ*_i, Σ_i = A_i⁻¹, η_i its integral — and where τ_i is not,
the points measure how it departs — within ±√3 Laplace σ only: at σ_z = 1 the target is a narrow peak on a base as
wide as Σ_u, and μ_i, Σ_i, η_i are the peak's, Σ_i several times narrower than the target's covariance and η_i short
of its integral by the base's mass; research/notebook/2026-11-23-rbpf-proposal-vs-target.md, checked against the brute-force target in
tests/mapping/test_rbpf.py.) The new pose is drawn from ``N(μ_i, Σ_i)`` and the weight multiplied by
η_i. When the match fails (too few end points on observed cells) the pose is drawn from the motion model and
the weight multiplied by ``p(z | m_i, ξ)`` at the drawn pose (the standard proposal's weight, the one-sample
estimate of the same η_i).

**Mode proposal** (``RBPFParams.proposal = "mode"``, what GMapping's code does: a motion-model draw, then the
scan matcher's optimum from it). With ``Λ = Σ_u⁻¹``:

    x_i ~ N(ĝ_i, Σ_u)                                   (3,)  the motion model's draw
    ξ*_i = mode of τ_i, Gauss-Newton from x_i            (3,)  (the basin x_i falls in); log η_i by the K points
    ξ_i  = argmax_ξ p(z | m_i, ξ) N(ξ; x_i, Σ_u)         (3,)  Gauss-Newton on the finest level from ξ*_i

For a Gaussian target (``log p(z | m, ξ) = c − ½ (ξ − ξ_z)ᵀ H_z (ξ − ξ_z)``, ``A = H_z + Λ``) the mode is
``ξ* = A⁻¹(H_z ξ_z + Λ ĝ)`` and the pose ``ξ = A⁻¹(H_z ξ_z + Λ x) = ξ* + A⁻¹Λ (x − ĝ)`` (the first Gauss-Newton step
from ξ*), so ``ξ ~ N(ξ*, A⁻¹ΛA⁻¹)``, ``A⁻¹ΛA⁻¹ = A⁻¹ − A⁻¹H_zA⁻¹ ⪯ A⁻¹``: along a direction where the scan adds
information h to the motion model's λ the variance is the fraction λ/(h + λ) of the target's — all of it where the scan
says nothing, almost none where it pins the pose. The weight is the target's η_i, as for the Gaussian proposal (the
exact importance weight η_i N(ξ_i; ξ*, A⁻¹) / N(ξ_i; ξ*, A⁻¹ΛA⁻¹) has infinite variance once h > λ);
research/method/rbpf_mode_proposal.md "The mode proposal" has the derivation and what it costs.

**Degeneracy** (``RBPFParams.degeneracy_threshold`` τ > 0; research/method/laser_degeneracy.md, rbpf.md). When the
translation block of the scan's geometric information (robot frame) has eigenvalues λ_0 < τ λ_1 (:func:`degeneracy`: a
corridor), u_0 is degenerate; for particle p, T_p = blockdiag(R(ψ_p) [u_0 u_1], 1) (3, 3) and c = T_pᵀ (ξ − ξ₀) its
coordinates, c_0 along the corridor. The scan is taken to say nothing about c_0 (its apparent information there is
the map's frontier pulling the scan back onto the mapped walls), so along c_0 the particle keeps its guess:

* every Gauss-Newton step moves in the kept directions only (ξ = ξ₀ + T_p c, c_0 = 0), and the mode proposal's motion
  draw has no component along t_0 (the first column of T_p): x_p = ĝ_p + (I − t_0 t_0ᵀ) L_u ε (L_u L_uᵀ = Σ_u);
* the weight integrates the motion model out along c_0 with the likelihood held at the guess's c_0,
  ``η_p = ∫ p(z | m_p, ξ°_p + T_p (0, c_1, c_2)) N((c_1, c_2); ĉ_p, S_p) dc_1 dc_2`` (ĉ_p the guess's kept
  coordinates, S_p their motion covariance; 9 points of the same rule in 2-D, :func:`_kept_quadrature`), so no
  particle is weighted by where along the corridor it is.

Drawing along c_0 from Σ_u instead (its σ_t ≥ 0.1 m is a search width, ten times a wheel odometry's noise per step) is
a random walk the scan never corrects: research/notebook/2026-11-28-rbpf-scale.md.

The per-particle loops over end points are numba kernels over all particles at once.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slamarena.datasets.geometry import wrap_angle, wrap_scalar

from ..scan_matching.gauss_newton import _solve3, accumulate_point, bilinear, scan_information, take_step
from .tiled_grid import TiledPyramid

__all__ = ["degeneracy", "degenerate_direction", "gauss_newton", "residuals", "quadrature", "NODES", "NODE_WEIGHTS"]

_U1 = np.array([-np.sqrt(3.0), 0.0, np.sqrt(3.0)])
_W1 = np.array([1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0])
#: the 27 Gauss–Hermite points u_j (27, 3) and weights w_j (27,) of the module docstring
NODES = np.stack(np.meshgrid(_U1, _U1, _U1, indexing="ij"), axis=-1).reshape(-1, 3)
NODE_WEIGHTS = np.prod(np.stack(np.meshgrid(_W1, _W1, _W1, indexing="ij"), axis=-1).reshape(-1, 3), axis=1)
#: the 9 points (9, 2) and weights (9,) of the same rule in two dimensions (a degenerate scan's kept coordinates)
NODES_2D = np.stack(np.meshgrid(_U1, _U1, indexing="ij"), axis=-1).reshape(-1, 2)
NODE_WEIGHTS_2D = np.prod(np.stack(np.meshgrid(_W1, _W1, indexing="ij"), axis=-1).reshape(-1, 2), axis=1)


@njit(cache=True, inline="always")
def _cell(pool, table, shift, l0, x, y):
    """Log-odds of cell (x, y) of the particle with tile table ``table``; tiles of side ``1 << shift``."""
    ty = y >> shift
    tx = x >> shift
    if x < 0 or y < 0 or ty >= table.shape[0] or tx >= table.shape[1]:
        return l0
    c = table[ty, tx]
    if c < 0:
        return l0
    mask = (1 << shift) - 1
    return pool[c, y & mask, x & mask]


@njit(cache=True)
def _interp(pool, table, shift, l0, ox, oy, res, wx, wy):
    """(M, ∂M/∂x, ∂M/∂y, observed) at a world point: bilinear on the cell centres (gauss_newton._interp)."""
    gx = (wx - ox) / res - 0.5
    gy = (wy - oy) / res - 0.5
    x0 = int(np.floor(gx))
    y0 = int(np.floor(gy))
    fx = gx - x0
    fy = gy - y0
    l00 = _cell(pool, table, shift, l0, x0, y0)
    l10 = _cell(pool, table, shift, l0, x0 + 1, y0)
    l01 = _cell(pool, table, shift, l0, x0, y0 + 1)
    l11 = _cell(pool, table, shift, l0, x0 + 1, y0 + 1)
    observed = l00 != l0 or l10 != l0 or l01 != l0 or l11 != l0
    M, dx, dy = bilinear(l00, l10, l01, l11, fx, fy, res, False)
    return M, dx, dy, observed


@njit(cache=True)
def _normal_equations(pool, table, shift, l0, ox, oy, res, pts, x, y, th):
    """H = Σ JᵀJ (3, 3), g = Σ Jᵀr (3,), Σ r², and the end points on observed cells."""
    c = np.cos(th)
    s = np.sin(th)
    H = np.zeros((3, 3))
    g = np.zeros(3)
    ssr = 0.0
    known = 0
    for i in range(pts.shape[0]):
        sx = pts[i, 0]
        sy = pts[i, 1]
        M, dMx, dMy, obs = _interp(pool, table, shift, l0, ox, oy, res, x + c * sx - s * sy, y + s * sx + c * sy)
        ssr += accumulate_point(H, g, M, dMx, dMy, sx, sy, c, s)
        known += obs
    H[1, 0] = H[0, 1]
    H[2, 0] = H[0, 2]
    H[2, 1] = H[1, 2]
    return H, g, ssr, known


#: the angle wrapped to (−π, π], compiled (:func:`~slamarena.datasets.geometry.wrap_scalar`)
_wrap = njit(cache=True)(wrap_scalar)


@njit(cache=True)
def _objective(H, g, ssr, info, inv_var, guess, x, y, th):
    """−log τ at ξ = (x, y, th) up to a constant, and A (3, 3), b (3,) of the Gauss-Newton step there (module docstring)."""
    e = np.empty(3)
    e[0] = guess[0] - x
    e[1] = guess[1] - y
    e[2] = _wrap(guess[2] - th)
    A = H * inv_var + info
    b = np.empty(3)
    f = 0.5 * ssr * inv_var
    for r in range(3):
        b[r] = g[r] * inv_var + info[r, 0] * e[0] + info[r, 1] * e[1] + info[r, 2] * e[2]
        f += 0.5 * e[r] * (info[r, 0] * e[0] + info[r, 1] * e[1] + info[r, 2] * e[2])
    return f, A, b


@njit(cache=True)
def _masked_step(A, b, T, keep):
    """The step T c (3,) with (TᵀAT) c = Tᵀb in the kept coordinates and c_j = 0 elsewhere, and whether it exists."""
    At = T.T @ A @ T
    bt = T.T @ b
    for j in range(3):
        if keep[j] == 0.0:
            At[j, :] = 0.0
            At[:, j] = 0.0
            At[j, j] = 1.0
            bt[j] = 0.0
    c, ok = _solve3(At, bt)
    return T @ c, ok


@njit(cache=True)
def _gauss_newton_level(
    pool,
    tables,
    shift,
    l0,
    ox,
    oy,
    res,
    pts,
    poses,
    guesses,
    info,
    inv_var,
    iterations,
    tol_t,
    tol_r,
    max_t,
    max_r,
    halvings,
    Ts,
    keep,
):
    """Gauss-Newton on −log τ (module docstring) for every particle from ``poses`` (P, 3), in place; returns
    the iterations taken (summed over the particles). ``halvings`` > 0: a step that does not lower −log τ is
    halved up to that many times, and the level stops where none does (0: every step is taken). Each step moves
    particle p by T_p c with c_j = 0 where ``keep[j]`` is 0 (the degenerate directions, module docstring; ``Ts``
    (P, 3, 3), T_p = I and keep = 1: every direction)."""
    total = 0
    for p in range(poses.shape[0]):
        table = tables[p]
        x = poses[p, 0]
        y = poses[p, 1]
        th = poses[p, 2]
        fresh = False  # whether f, A, b are those of (x, y, th) already (a halving step evaluated them)
        for _ in range(iterations):
            total += 1
            if not fresh:
                H, g, ssr, known = _normal_equations(pool, table, shift, l0, ox, oy, res, pts, x, y, th)
                f, A, b = _objective(H, g, ssr, info, inv_var, guesses[p], x, y, th)
            d, ok = _masked_step(A, b, Ts[p], keep)
            if not ok:
                break
            if halvings == 0:
                x, y, th, converged = take_step(d, x, y, th, max_t, max_r, tol_t, tol_r)
            else:
                accepted = False
                for _h in range(halvings + 1):
                    nx, ny, nth, converged = take_step(d.copy(), x, y, th, max_t, max_r, tol_t, tol_r)
                    H, g, ssr, known = _normal_equations(pool, table, shift, l0, ox, oy, res, pts, nx, ny, nth)
                    nf, nA, nb = _objective(H, g, ssr, info, inv_var, guesses[p], nx, ny, nth)
                    if nf <= f:
                        accepted = True
                        break
                    d *= 0.5
                if not accepted:
                    break
                x, y, th, f, A, b, fresh = nx, ny, nth, nf, nA, nb, True
            if converged:
                break
        poses[p, 0] = x
        poses[p, 1] = y
        poses[p, 2] = th
    return total


@njit(cache=True)
def _at(pool, tables, shift, l0, ox, oy, res, pts, X):
    """Σ r² (P, K) at the poses X (P, K, 3), and H (P, 3, 3) and the observed end points (P,) at X[:, 0]."""
    P, K = X.shape[0], X.shape[1]
    ssr = np.empty((P, K))
    Hs = np.empty((P, 3, 3))
    known = np.empty(P, np.int64)
    for p in range(P):
        for k in range(K):
            H, g, s, n = _normal_equations(
                pool, tables[p], shift, l0, ox, oy, res, pts, X[p, k, 0], X[p, k, 1], X[p, k, 2]
            )
            ssr[p, k] = s
            if k == 0:
                Hs[p] = H
                known[p] = n
    return ssr, Hs, known


def gauss_newton(
    maps: TiledPyramid,
    pts,
    guesses,
    info,
    sigma: float,
    iterations: int,
    tol_t: float,
    tol_r: float,
    max_step_t: float,
    max_step_r: float,
    start=None,
    finest_only: bool = False,
    halvings: int = 0,
    basis: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, int]:
    """Modes (P, 3) of −log τ for every particle, the motion prior centred on the guesses (P, 3) (``info`` = Σ_u⁻¹
    (3, 3)), coarse to fine (or on the finest level only) from ``start`` (P, 3; default: the guesses), and the
    iterations taken (summed over levels and particles); ``halvings`` as ``RBPFParams.step_halvings``; ``basis`` =
    (T (3, 3), keep (3,)) of :func:`degeneracy` in the robot frame keeps the degenerate directions where they start
    (None: every direction moves)."""
    poses = np.array(guesses if start is None else start, dtype=np.float64)
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    Ts, keep = _particle_bases(basis, guesses)
    fine = maps.finest.resolution
    iterations_taken = 0
    for grid in maps.levels[:1] if finest_only else reversed(maps.levels):
        iterations_taken += _gauss_newton_level(
            grid.pool,
            grid.table,
            grid.shift,
            np.float32(grid.l0),
            grid.origin[0],
            grid.origin[1],
            grid.resolution,
            pts,
            poses,
            np.ascontiguousarray(guesses, dtype=np.float64),
            np.ascontiguousarray(info, dtype=np.float64),
            1.0 / sigma**2,
            iterations,
            tol_t,
            tol_r,
            max_step_t * grid.resolution / fine,
            max_step_r,
            halvings,
            Ts,
            keep,
        )
    poses[:, 2] = wrap_angle(poses[:, 2])
    return poses, iterations_taken


def degeneracy(pts, threshold: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(T (3, 3), keep (3,)) in the robot frame when the scan ``pts`` (N, 2) is degenerate in translation, else None:
    u_0, u_1 the eigenvectors of the translation block of the scan's geometric information
    (:func:`~slamarena.mapping.scan_matching.gauss_newton.scan_information` at ξ = 0), eigenvalues λ_0 ≤ λ_1,
    degenerate when λ_0 < threshold · λ_1; T = blockdiag([u_0 u_1], 1), keep = (0, 1, 1)."""
    lam, U = np.linalg.eigh(scan_information(np.asarray(pts, dtype=float), np.zeros(3))[:2, :2])
    if not lam[0] < threshold * lam[1]:
        return None
    T = np.eye(3)
    T[:2, :2] = U
    return T, np.array([0.0, 1.0, 1.0])


def _particle_bases(basis, poses) -> tuple[np.ndarray, np.ndarray]:
    """Every particle's basis T_p = blockdiag(R(ψ_p), 1) T (P, 3, 3) from the robot frame's, and keep (3,); identities
    when ``basis`` is None."""
    P = len(poses)
    if basis is None:
        return np.ascontiguousarray(np.broadcast_to(np.eye(3), (P, 3, 3))), np.ones(3)
    T, keep = basis
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    R = np.zeros((P, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    return np.ascontiguousarray(R @ T), keep


def degenerate_direction(basis: tuple[np.ndarray, np.ndarray], poses) -> np.ndarray:
    """The degenerate direction t_0 (P, 3) in the world frame at each of the poses (P, 3): the first column of T_p
    (:func:`degeneracy`'s basis turned by the pose's heading; no rotation component)."""
    return _particle_bases(basis, poses)[0][:, :, 0]


def residuals(maps: TiledPyramid, pts, X) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """On the finest level: Σ r² (P, K) at poses X (P, K, 3); H (P, 3, 3) and observed end points (P,) at X[:, 0]."""
    grid = maps.finest
    return _at(
        grid.pool,
        grid.table,
        grid.shift,
        np.float32(grid.l0),
        grid.origin[0],
        grid.origin[1],
        grid.resolution,
        np.ascontiguousarray(pts, dtype=np.float64),
        np.ascontiguousarray(X, dtype=np.float64),
    )


def log_gaussian(d, cov) -> np.ndarray:
    """log N(d; 0, cov) for differences d (…, 3) (angle already wrapped) and one covariance (3, 3)."""
    L = np.linalg.cholesky(cov)
    z = np.linalg.solve(L, d.reshape(-1, 3).T).T.reshape(d.shape)
    return -0.5 * np.sum(z**2, axis=-1) - np.log(np.diag(L)).sum() - 1.5 * np.log(2 * np.pi)


def quadrature(maps: TiledPyramid, pts, modes, guesses, motion_cov, sigma: float, basis=None):
    """μ (P, 3), Σ (P, 3, 3), log η (P,) and the observed end points (P,) of the module docstring; with ``basis``
    (:func:`degeneracy`) the scan is taken to say nothing along the degenerate direction (:func:`_kept_quadrature`)."""
    if basis is not None:
        return _kept_quadrature(maps, pts, modes, guesses, motion_cov, sigma, basis)
    ssr0, H, known = residuals(maps, pts, modes[:, None, :])
    A_inv = np.linalg.inv(H / sigma**2 + np.linalg.inv(motion_cov))
    L = np.linalg.cholesky(A_inv)  # (P, 3, 3)
    D = np.einsum("pij,kj->pki", L, NODES)  # ξ_ij − ξ*_i (P, K, 3)
    X = modes[:, None, :] + D
    ssr, _, _ = residuals(maps, pts, X)
    e = X - guesses[:, None, :]
    e[..., 2] = wrap_angle(e[..., 2])
    log_tau = -0.5 * ssr / sigma**2 + log_gaussian(e, motion_cov)
    log_eta, w = _log_integral(log_tau, NODES, NODE_WEIGHTS, L)
    dm = np.einsum("pk,pki->pi", w, D)
    R = D - dm[:, None, :]
    cov = np.einsum("pk,pki,pkj->pij", w, R, R)
    mu = modes + dm
    mu[:, 2] = wrap_angle(mu[:, 2])
    return mu, cov, log_eta, known


def _log_integral(log_tau, nodes, node_weights, L) -> tuple[np.ndarray, np.ndarray]:
    """log η (P,) = log(|L| Σ_j c_j), c_j = w_j τ(ξ_j)/φ(u_j), from log τ (P, K) at the points of the d-dimensional rule
    ``nodes`` (K, d), ``node_weights`` (K,) scaled by L (P, d, d); and the normalised c_j (P, K)."""
    d = nodes.shape[1]
    log_c = np.log(node_weights) + log_tau + 0.5 * np.sum(nodes**2, axis=1) + 0.5 * d * np.log(2 * np.pi)
    top = log_c.max(axis=1, keepdims=True)
    c = np.exp(log_c - top)
    total = c.sum(axis=1)
    return np.log(np.abs(np.linalg.det(L))) + top[:, 0] + np.log(total), c / total[:, None]


def _kept_quadrature(maps: TiledPyramid, pts, modes, guesses, motion_cov, sigma: float, basis):
    """The quadrature of a degenerate scan (module docstring, "Degeneracy"). In particle p's coordinates
    c = T_pᵀ (ξ − ξ°_p) (T_p (P, 3, 3) of :func:`_particle_bases`, c_0 along the corridor) the scan likelihood is taken
    to be constant along c_0 at the guess's c_0: the centre ξ°_p is the mode ξ*_p moved along u_0 to the guess ĝ_p,
    ξ°_p = ξ*_p + t_0 t_0ᵀ (ĝ_p − ξ*_p) (t_0 the first column of T_p). Then (the motion Gaussian integrates out along c_0)

        η_p = ∫ p(z | m_p, ξ°_p + T_p (0, c_1, c_2)) N((c_1, c_2); ĉ_p, S_p) dc_1 dc_2          S_p = (T_pᵀ Σ_u T_p)[1:, 1:]

    (ĉ_p = [T_pᵀ (ĝ_p − ξ°_p)]_{1:}, the guess's kept coordinates) by the 9-point 2-D rule on the Laplace covariance
    of the kept coordinates, (H_kk/σ_z² + S_p⁻¹)⁻¹ with H_kk = (T_pᵀ H T_p)[1:, 1:], H at ξ°_p: the weight does not
    depend on where along the corridor the mode is. μ_p = ξ°_p + T_p (0, m_1, m_2) and Σ_p = T_p blockdiag(0, C) T_pᵀ
    with m, C (2,), (2, 2) the points' moments: along the corridor the proposal is the guess."""
    Ts, _ = _particle_bases(basis, guesses)  # as the Gauss-Newton steps: T_p at the guess
    Tt = np.swapaxes(Ts, 1, 2)
    t0 = Ts[:, :, 0]  # degenerate_direction
    centre = modes + t0 * np.einsum("pi,pi->p", t0, guesses - modes)[:, None]
    _, H, known = residuals(maps, pts, centre[:, None, :])
    S = (Tt @ motion_cov @ Ts)[:, 1:, 1:]  # (P, 2, 2)
    A_inv = np.linalg.inv((Tt @ H @ Ts)[:, 1:, 1:] / sigma**2 + np.linalg.inv(S))
    L = np.linalg.cholesky(0.5 * (A_inv + np.swapaxes(A_inv, 1, 2)))  # (P, 2, 2)
    D2 = np.einsum("pij,kj->pki", L, NODES_2D)  # kept coordinates of the points − the centre's (P, 9, 2)
    D = np.einsum("pij,pkj->pki", Ts[:, :, 1:], D2)  # (P, 9, 3)
    X = centre[:, None, :] + D
    ssr, _, _ = residuals(maps, pts, X)
    e = X - guesses[:, None, :]
    e[..., 2] = wrap_angle(e[..., 2])
    ek = np.einsum("pij,pkj->pki", Tt, e)[..., 1:]  # (P, 9, 2)
    z = np.einsum("pij,pkj->pki", np.linalg.inv(np.linalg.cholesky(S)), ek)
    log_motion = -0.5 * np.sum(z**2, axis=-1) - 0.5 * np.log(np.linalg.det(S))[:, None] - np.log(2 * np.pi)
    log_eta, w = _log_integral(-0.5 * ssr / sigma**2 + log_motion, NODES_2D, NODE_WEIGHTS_2D, L)
    dm = np.einsum("pk,pki->pi", w, D2)
    R = D2 - dm[:, None, :]
    cov_c = np.zeros((len(modes), 3, 3))  # no spread along c_0
    cov_c[:, 1:, 1:] = np.einsum("pk,pki,pkj->pij", w, R, R)
    mu = centre + np.einsum("pij,pj->pi", Ts[:, :, 1:], dm)
    mu[:, 2] = wrap_angle(mu[:, 2])
    return mu, Ts @ cov_c @ Tt, log_eta, known
