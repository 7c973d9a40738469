"""FastSLAM 1.0 and 2.0 (Montemerlo et al. 2002, 2003): a Rao-Blackwellised particle filter for landmark SLAM.

Factorisation
-------------
    p(x_{1:t}, m | z_{1:t}, u_{1:t}) = p(x_{1:t} | z_{1:t}, u_{1:t}) · Π_j p(m_j | x_{1:t}, z_{1:t})

The path posterior is represented by M particles; given a particle's path the landmarks are
independent, so each particle carries one 2 × 2 EKF per landmark (mean μ (2,), covariance Σ (2, 2)).

State layout (M particles, n_m landmarks of particle m)
------------------------------------------------------
    x0      (M, 3)   each particle's pose at its last sampling [m, m, rad]
    Δ, Σ_Δ  (3,), (3, 3)  the motion since the last sampling, composed in the frame of the pose at that
                     sampling, and its covariance — the same for every particle (the controls are)
    log w   (M,)     log weights (normalised to max 0 after every update)
    maps             copy-on-write landmark trees shared between particles (:mod:`.storage`)
    n_slots, n_live  (M,) each particle's slots in use and live landmarks (kept by the update, resampled
                     with the particles, so no per-step count walks a map)

Prediction (between samplings)
------------------------------
A control u = (v, ω) held for dt gives the body-frame increment δ = δ(u, dt) with covariance
C = V M Vᵀ (V = ∂δ/∂u (3, 2), M the twist covariance (2, 2), the EKF-SLAM "control" noise model), or with a stated row
period T (``twist_period``) C = (T / dt) V M Vᵀ: white velocity noise of density M T, so that rows of irregular length
(MRCLAM: 0.01–1 s) carry the stated error per second and not M per row (for rows of period T the two are the same);
an odometry increment δ comes with its own C (3, 3). The chain is composed once for all particles:

    Δ ← Δ ⊕ δ,   Σ_Δ ← J_Δ Σ_Δ J_Δᵀ + J_δ C J_δᵀ      (J_Δ, J_δ = ∂(Δ ⊕ δ)/∂Δ, ∂/∂δ, (3, 3) each)

so that particle m's predicted pose and its covariance are

    x̂_m = x0_m ⊕ Δ,   P_m = J_m Σ_Δ J_mᵀ,   J_m = blockdiag(R(θ0_m), 1)        (3,), (3, 3)

(exact for the composition: x0 ⊕ Δ is linear in Δ for a fixed x0). A chain is sampled at every
observation set, and at least every ``max_chain`` seconds without one (x0_m ← x̂_m + A_m ε_m,
A_m A_mᵀ = P_m): so the Gaussian chain replaces per-step sampling only over short stretches.

Update (per observation set z (k, 2), :mod:`.kernels`)
-----------------------------------------------------
FastSLAM 1.0 samples x_m ~ N(x̂_m, P_m) (the motion model) and weights by the landmarks' innovation
likelihoods; FastSLAM 2.0 first conditions the Gaussian on the observations (one EKF step of the pose
per observation, with the landmark's uncertainty in the measurement noise), samples from that proposal
and weights by its normaliser. Both then update each observed landmark's EKF at the sampled pose.
Known association uses the ids; with ``use_ids=False`` every particle associates on its own by
maximum likelihood, with existence counters where a perceptual field is stated (``max_range``, ``fov``),
and (``confirm_sightings`` = k > 1) tentative landmarks: a landmark a particle starts is no evidence about
its path — its sightings take the new-landmark likelihood and do not condition the proposal — until it has
been seen k times within ``confirm_window`` seconds of its start, and is removed if it has not (per particle,
the analogue of EKF-SLAM's ``LandmarkBook``).

Heavy-tailed sensor (``huber_k`` = k)
------------------------------------
A row's log-likelihood −ρ_k(d) − ½ log det S − log 2π, ρ_k(d) = d²/2 (d ≤ k), k d − k²/2 (d > k), an outlier's noise
inflated by d / k in the proposal and the landmark update (:mod:`.kernels`); the association gate γ is the Huber
density's quantile, P(d² > γ) = 1 − ``association_confidence`` (:func:`huber_gate`), and p₀ = −ρ_k(√γ) − ½ log det R_j
− log 2π. None: the Gaussian (ρ = d²/2, γ the χ²₂ quantile).

Resampling
----------
    ŵ = exp(log w − logsumexp(log w)),   N_eff = 1 / Σ ŵ²
When N_eff < ``resample_threshold`` · M, particles are drawn with low-variance (systematic)
resampling — one uniform u₀ ~ U[0, 1/M), pointers u₀ + i/M through the cumulative weights — and the
weights reset to uniform. Maps are shared after resampling: copying a particle is O(1) (its root),
and a later write copies O(log n) nodes (:mod:`.storage`).

Ancestry (the depletion diagnostic)
-----------------------------------
The particles represent the map's uncertainty only back to their most recent common ancestor: before
its time t_A every particle carries the same path, so the same map of what was seen then. ``t_A``
(:attr:`FastSLAM.common_ancestor_t`) is kept exactly in O(M) per resampling. Systematic resampling
gives non-decreasing ancestors (a_m ≤ a_{m+1}), so lineages never cross and the lineages of particles
m < l < m' lie between those of m and m'. Hence, with s_m (M − 1,) the time at which the lineages of
neighbours m and m + 1 last shared an ancestor (the start t₀ for the initial particles, all drawn from
one prior),

    s'_m = t                                   if a_m = a_{m+1}   (t: the resampling's time)
    s'_m = min(s_{a_m}, …, s_{a_{m+1} − 1})    otherwise,
    t_A  = min_m s_m.

Bad input (:mod:`slamarena.estimators.inputs`, as EKF-SLAM)
----------------------------------------------------------
Every step checks its input and its result before the state changes. A prediction with ``dt ≤ 0``, a
non-finite control or increment, or whose Δ, Σ_Δ or predicted poses are not finite (``v = 1e300``: Σ_Δ
overflows) raises ``ValueError``; one whose Σ_Δ is not positive semi-definite (an increment covariance
−I) raises ``CovarianceError``. An update's stamp must be finite and not before the last update's
(``ValueError``). Observation rows with a non-finite value or a negative range, and rows the particles
cannot represent (a new landmark whose mean or covariance G_z R G_zᵀ is not finite, an infinite d² to a
mapped landmark: a range of 1e300 m), are dropped and counted in ``rejected``; the update is then the
update of the set without them.

Randomness comes from one ``numpy.random.Generator`` seeded by ``seed``; the same seed gives the same run.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import NonNegativeInt, PositiveFloat, PositiveInt, model_validator

from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.params import Covariance2, Covariance3, Field, Params, Probability

from ..inputs import CovarianceError, first_indefinite, next_stamp, valid_rows
from ..models import (
    DEFAULT_RANGE_BEARING_COV,
    MOTION_MODELS,
    UNSTATED_TWIST_COV,
    RangeBearingNoise,
    TwistPeriod,
    chi2_gate,
    compose_chain,
    compose_jacobians,
    inverse_observation_jacobians,
    inverse_observe,
    noise_in_force,
    observation_covariances,
    twist_increment_cov,
)
from ..stepping import StepClock
from .kernels import huber_rho, predictive_d2, sqrt_psd, update_particles
from .storage import LandmarkStore

__all__ = ["FastSLAM", "FastSLAMParams"]


class FastSLAMParams(Params):
    """Parameters of :class:`FastSLAM`."""

    version: Literal[1, 2] = Field(
        2, description="1: proposal = motion model; 2: proposal conditioned on the observations"
    )
    particles: PositiveInt = Field(100, description="number of particles M")
    motion_model: Literal["arc", "euler"] = Field("arc", description="motion model of Twist input (estimators.models)")
    twist_cov: Covariance2 | None = Field(
        None,
        description="covariance M of one (v, ω) row [(m/s)², (rad/s)²]; None: the sequence's noise, else UNSTATED_TWIST_COV "
        "(estimators.models: MRCLAM's identified twist noise, as EKF-SLAM)",
    )
    twist_period: TwistPeriod = None
    increment_cov: Covariance3 | None = Field(
        None, description="covariance of an odometry increment [m², m², rad²]; None: the row's, else the sequence's"
    )
    range_bearing_cov: Covariance2 | None = Field(
        None,
        description="covariance R of a (range, bearing) observation [m², rad²]; None: the sequence's noise, else the EKF-SLAM default",
    )
    range_bearing_noise: RangeBearingNoise = Field(
        RangeBearingNoise.POLAR,
        description="polar: R for every observation; "
        "cartesian: isotropic σ² = R[0,0] in the plane, R_j = diag(σ², σ²/r_j²) (Victoria Park)",
    )
    use_ids: bool = Field(True, description="associate by the ids in the data; False: per-particle maximum likelihood")
    known_confidence: Probability | None = Field(
        None,
        description="χ²₂ gate on a labelled row of a mapped landmark: rejected (for every particle) when, for particles of more than "
        "half the weight, its d² at the predicted pose is beyond χ²₂(known_confidence) — EKF-SLAM's gate; None: no gate",
    )
    association_confidence: Probability = Field(
        0.9999,
        description="χ²₂ gate of a maximum-likelihood match (a true re-observation falls beyond it with probability 1 − confidence); "
        "an observation with no landmark inside it starts a landmark, weighted by the sensor density at the gate",
    )
    huber_k: PositiveFloat | None = Field(
        None,
        description="Huber width k [σ of the whitened innovation]: a row's log-likelihood takes −ρ_k(d) for −d²/2 (the same "
        "inside k, linear in d beyond), and an outlier's noise is inflated by d / k in the proposal and the landmark "
        "update, and the association gate is the Huber density's quantile (huber_gate); None: Gaussian",
    )
    association_pose: Literal["proposal", "predicted"] = Field(
        "proposal",
        description="FastSLAM 2.0 without ids: gate and choose each row's landmark at the proposal conditioned on the rows "
        "before it (proposal), or at the predicted pose and its covariance, the same for every row (predicted)",
    )
    confirm_sightings: PositiveInt = Field(
        1,
        description="unknown association: a landmark a particle starts is tentative "
        "(its sightings weigh as new landmarks and do not condition "
        "the proposal) until seen this many times (the first included) within confirm_window, and removed if not; 1: confirmed at once",
    )
    confirm_window: PositiveFloat = Field(
        math.inf, description="time [s] from its start a tentative landmark has to reach confirm_sightings"
    )
    max_range: PositiveFloat | None = Field(
        None, description="perceptual range [m] for the existence counters (unknown association); None: no counters"
    )
    fov: float | None = Field(
        None, gt=0.0, le=2 * math.pi, description="full field of view [rad] for the existence counters; None: all round"
    )
    resample_threshold: float = Field(0.5, gt=0.0, le=1.0, description="resample when N_eff < threshold · M")
    max_chain: PositiveFloat = Field(
        1.0, description="sample from the motion model at least this often without observations [s]"
    )
    trajectory: Literal["mean", "best"] = Field(
        "mean",
        description="the Estimate's poses: the weighted mean at each stamp (a filter's estimate), "
        "or the ancestral path of the particle of largest final weight",
    )
    initial_cov: Covariance3 = Field(
        0.0, description="covariance of the start pose the particles are drawn from [m², m², rad²]"
    )
    seed: NonNegativeInt = Field(0, description="seed of the random generator")
    step_clock: StepClock = Field(
        "wall", description="clock of run()'s step_time: wall time, or the process's CPU time (all threads) [s]"
    )

    @model_validator(mode="after")
    def _field_of_view_needs_a_range(self):
        if self.fov is not None and self.max_range is None:
            raise ValueError("fov is the perceptual field of the existence counters and needs max_range")
        if self.confirm_sightings > 1 and self.use_ids:
            raise ValueError(
                "confirm_sightings > 1 decides which landmarks a particle keeps without ids; with use_ids the ids decide"
            )
        return self


class FastSLAM:
    """FastSLAM 1.0 / 2.0 (module docstring). Step interface: ``predict(u, dt)``, ``update(z)``; ``run(sequence)``."""

    Params = FastSLAMParams

    def __init__(self, params: FastSLAMParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.model = MOTION_MODELS[self.params.motion_model]
        self.huber_k = math.inf if self.params.huber_k is None else float(self.params.huber_k)
        self.gate = huber_gate(self.params.association_confidence, self.huber_k)
        self.gate_known = chi2_gate(self.params.known_confidence, 2)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, sequence=None) -> None:
        """Start over: every particle at the start pose (of ``sequence``, else the origin), noise resolved."""
        p = self.params
        self.M_twist = noise_in_force(p.twist_cov, sequence, "twist_cov", UNSTATED_TWIST_COV)
        self.R = noise_in_force(p.range_bearing_cov, sequence, "range_bearing_cov", DEFAULT_RANGE_BEARING_COV)
        self.increment_cov = noise_in_force(p.increment_cov, sequence, "increment_cov")
        self.rng = np.random.default_rng(p.seed)
        start = sequence.start_pose if sequence is not None else np.zeros(3)
        M = p.particles
        P0 = np.asarray(p.initial_cov)
        self.x0 = np.tile(np.asarray(start, dtype=float), (M, 1)) + self.rng.standard_normal((M, 3)) @ sqrt_psd(P0).T
        self.x0[:, 2] = wrap_angle(self.x0[:, 2])
        self.delta = np.zeros(3)
        self.Sigma_delta = np.zeros((3, 3))
        self.log_w = np.zeros(M)
        self.store = LandmarkStore(M)
        self.n_slots = np.zeros(M, dtype=np.int64)
        self.n_live = np.zeros(M, dtype=np.int64)
        self._slot_of_id: dict[int, int] = {}
        self._id_of_slot: list[int] = []
        self.rejected = {"nonfinite": 0, "negative_range": 0, "gate": 0}
        self.resamplings = 0
        self._sets = 0
        self._t = float(getattr(sequence, "t0", 0.0))
        self._last_stamp: float | None = None  # the last update's t
        self.split_t = np.full(
            M - 1, self._t
        )  # s_m: when the lineages of particles m and m + 1 last met (module docstring)

    @property
    def M(self) -> int:
        return self.params.particles

    @property
    def weights(self) -> np.ndarray:
        """Normalised weights ŵ (M,)."""
        w = np.exp(self.log_w - self.log_w.max())
        return w / w.sum()

    @property
    def n_eff(self) -> float:
        """Effective sample size 1 / Σ ŵ²."""
        return float(1.0 / np.sum(self.weights**2))

    @property
    def common_ancestor_t(self) -> float:
        """t_A: the time of the particles' most recent common ancestor (the start while they have none since it)."""
        return float(self.split_t.min()) if self.split_t.size else self._t

    def predicted(self) -> tuple[np.ndarray, np.ndarray]:
        """Every particle's predicted pose x̂ = x0 ⊕ Δ (M, 3) and its covariance P = J Σ_Δ Jᵀ (M, 3, 3)."""
        return self._predicted(self.delta, self.Sigma_delta)

    def _predicted(self, delta, Sigma):
        J = compose_jacobians(self.x0, delta)[1]
        return compose(self.x0, delta), J @ Sigma @ np.swapaxes(J, -1, -2)

    @property
    def poses(self) -> np.ndarray:
        """The particles' current (predicted) poses (M, 3)."""
        return self.predicted()[0]

    # ------------------------------------------------------------------ prediction
    def predict(self, u, dt: float) -> None:
        """Propagate with the control u = [v, ω] held for dt > 0 seconds."""
        u = np.asarray(u, dtype=float).reshape(2)
        self.predict_twists(u[:1], u[1:], np.array([dt], dtype=float))

    def predict_twists(self, v, omega, dt) -> tuple[np.ndarray, np.ndarray]:
        """A chain of controls (v_k, ω_k) held for dt_k; returns Δ and Σ_Δ after each piece ((K, 3), (K, 3, 3))."""
        v, omega, dt = (np.asarray(a, dtype=float).reshape(-1) for a in (v, omega, dt))
        if not np.all(np.isfinite(dt) & (dt > 0)):
            raise ValueError(
                f"predict: dt must be finite and > 0, got {dt[~(np.isfinite(dt) & (dt > 0))][:3].tolist()}"
            )
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(omega))):
            raise ValueError("predict: controls must be finite")
        with np.errstate(over="ignore", invalid="ignore"):  # an absurd control overflows; _chain checks the result
            delta = self.model.increment(v, omega, dt)
            V = self.model.jacobians(np.zeros(3), v, omega, dt)[1]
            C = twist_increment_cov(V @ self.M_twist @ np.swapaxes(V, 1, 2), dt, self.params.twist_period)
        return self._chain(delta, C)

    def predict_increments(self, delta, cov=None) -> tuple[np.ndarray, np.ndarray]:
        """A chain of body-frame odometry increments (K, 3) with covariances (K, 3, 3) (default ``increment_cov``)."""
        delta = np.asarray(delta, dtype=float).reshape(-1, 3)
        C = self.increment_cov if cov is None else cov
        if C is None:
            raise ValueError(
                "predict_increments: no increment covariance (give cov, increment_cov, or Noise.increment_cov)"
            )
        C = np.broadcast_to(np.asarray(C, dtype=float), (len(delta), 3, 3))
        if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(C))):
            raise ValueError("predict_increments: increments and covariances must be finite")
        return self._chain(delta, C)

    def _chain(self, delta: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Δ ← Δ ⊕ δ_1 ⊕ … ⊕ δ_K with Σ_Δ, computed and checked before the state changes: a chain whose Δ, Σ_Δ or
        predicted poses x0 ⊕ Δ are not finite raises ``ValueError``, one whose Σ_Δ is not positive semi-definite
        :class:`~slamarena.estimators.inputs.CovarianceError` (e.g. an increment covariance −I)."""
        if len(delta) == 0:
            return np.zeros((0, 3)), np.zeros((0, 3, 3))
        with np.errstate(over="ignore", invalid="ignore"):  # an absurd input overflows; checked below
            deltas, Sigmas = compose_chain(self.delta, self.Sigma_delta, delta, C)
            poses = compose(self.x0, deltas[-1])
        bad = np.flatnonzero(~np.all(np.isfinite(deltas), axis=1))
        k = int(first_indefinite(np.ascontiguousarray(Sigmas)))
        if bad.size or not np.all(np.isfinite(poses)) or (k >= 0 and not np.all(np.isfinite(Sigmas[k]))):
            k = int(bad[0]) if bad.size else (k if k >= 0 else len(delta) - 1)
            raise ValueError(
                f"prediction {k} of {len(delta)} gives a non-finite pose or covariance (the motion or its covariance "
                "is beyond what the model can represent); the state is unchanged"
            )
        if k >= 0:
            raise CovarianceError(
                f"prediction {k} of {len(delta)}: the motion covariance Σ_Δ is not positive semi-definite "
                f"({Sigmas[k].tolist()}); the state is unchanged"
            )
        self.delta, self.Sigma_delta = deltas[-1], Sigmas[-1]
        return deltas, Sigmas

    def sample_motion(self) -> None:
        """Draw every particle from its predicted Gaussian and start a new chain (no observation)."""
        xhat, P = self.predicted()
        eps = self.rng.standard_normal((self.M, 3))
        self.x0 = xhat + np.einsum("mij,mj->mi", _sqrt_batch(P), eps)
        self.x0[:, 2] = wrap_angle(self.x0[:, 2])
        self.delta = np.zeros(3)
        self.Sigma_delta = np.zeros((3, 3))

    # ------------------------------------------------------------------ update
    def update(self, z, t: float | None = None) -> np.ndarray:
        """Apply one observation set z (k, 3) = rows [range, bearing, id] taken at time t [s] (None: the number of sets so
        far; the clock of the tentative landmarks); returns the slot each particle gave each row (M, k).

        Rows with a non-finite value or a negative range are rejected and counted, and so is a row the particles cannot
        represent (counted in ``rejected["nonfinite"]``, :meth:`_representable`); with ``use_ids`` a negative id is
        rejected as unlabelled. A rejected row changes nothing: the update is the one of the set without it. The stamp t
        must be finite and not before the last update's (else ``ValueError``, nothing changed). Resamples when N_eff
        falls below the threshold.
        """
        t = next_stamp(self._sets + 1 if t is None else t, self._last_stamp)
        z, finite, negative = valid_rows(z)
        self.rejected["nonfinite"] += int((~finite).sum())
        self.rejected["negative_range"] += int(negative.sum())
        p = self.params
        if p.use_ids:
            z = z[z[:, 2] >= 0]
        R = self._noise(z)
        xhat, P = self.predicted()
        keep = self._representable(z, R, xhat)
        z, R = z[keep], R[keep]
        if p.use_ids:
            _, first = np.unique(z[:, 2].astype(np.int64), return_index=True)
            first = np.sort(first)  # one row per landmark per set
            z, R = z[first], R[first]
        slots = (
            np.array([self._slot(int(i)) for i in z[:, 2]], dtype=np.int64)
            if p.use_ids
            else np.zeros(len(z), dtype=np.int64)
        )
        if p.use_ids and len(z):
            z, slots, R = self._gated(z, slots, R, xhat, P)
        self._sets += 1
        self._t = self._last_stamp = t
        eps = self.rng.standard_normal((self.M, 3))
        poses = np.empty((self.M, 3))
        assoc = np.full((self.M, len(z)), -1, dtype=np.int64)
        if len(z):
            top = int(slots.max()) if p.use_ids else int(self.n_slots.max()) + len(z)
            self.store.reserve(top, self.M * (len(z) + (0 if p.use_ids else int(self.n_slots.max()))))
            log_p0 = (
                -huber_rho(self.gate, self.huber_k) - 0.5 * np.log(np.linalg.det(R)) - math.log(2 * math.pi)
            )  # (k,): each row's own R_j; −ρ(γ) = −γ/2 without the Huber weight
            max_range = p.max_range if (p.max_range is not None and not p.use_ids) else 0.0
            half_fov = 0.5 * (p.fov if p.fov is not None else 2 * math.pi)
            update_particles(
                p.version,
                p.use_ids,
                xhat,
                P,
                eps,
                self.log_w,
                np.ascontiguousarray(z[:, :2]),
                slots,
                self.n_slots,
                self.n_live,
                R,
                self.gate,
                log_p0,
                self.huber_k,
                p.association_pose == "predicted",
                max_range,
                half_fov,
                p.confirm_sightings,
                p.confirm_window,
                t,
                self.store.depth,
                *self.store.kernel_args(),
                poses,
                assoc,
            )
        else:
            poses = xhat + np.einsum("mij,mj->mi", _sqrt_batch(P), eps)
            poses[:, 2] = wrap_angle(poses[:, 2])
        self.x0 = poses
        self.delta = np.zeros(3)
        self.Sigma_delta = np.zeros((3, 3))
        self.log_w -= self.log_w.max()
        self.last_sampled, self.last_log_w, self.last_ancestors = poses.copy(), self.log_w.copy(), None
        if self.n_eff < p.resample_threshold * self.M:
            self.resample()
        return assoc

    def _representable(self, z: np.ndarray, R: np.ndarray, xhat: np.ndarray) -> np.ndarray:
        """The rows (k,) whose new landmark is finite at every particle's predicted pose — its mean x̂_m ⊞ z and its
        covariance G_z R_j G_zᵀ — and whose r² is finite (the innovations' scale); the others are counted as non-finite.

        The definition of an absurd range is the EKF-SLAM one: one the model cannot represent (e.g. 1e300 m, whose
        covariance overflows), not a bound on range; a reader drops ranges outside its sensor's physical range."""
        with np.errstate(over="ignore", invalid="ignore"):
            mean = inverse_observe(xhat[:, None, :], z[None, :, :2])  # (M, k, 2)
            Gz = inverse_observation_jacobians(xhat[:, None, :], z[None, :, :2])[1]  # (M, k, 2, 2)
            cov = Gz @ R[None] @ np.swapaxes(Gz, -1, -2)
            ok = (
                np.isfinite(z[:, 0] * z[:, 0])
                & np.all(np.isfinite(mean), axis=(0, 2))
                & np.all(np.isfinite(cov), axis=(0, 2, 3))
            )
        self.rejected["nonfinite"] += int((~ok).sum())
        return ok

    def _gated(self, z, slots, R, xhat, P):
        """The rows of a labelled set whose d² is finite at every particle's predicted pose (the others are counted as
        non-finite) and that pass the known-landmark gate (``known_confidence``; counted as ``gate``).

        A row is an outlier when the particles that consider it one — d² = νᵀ L⁻¹ ν at their predicted pose beyond
        χ²₂(known_confidence), :func:`.kernels.predictive_d2` — hold more than half the weight. Decided once for the
        row, before any particle uses it, so that it changes no particle or none (a per-particle gate would reward the
        particles that reject it). A row of a landmark no particle has mapped yet always passes.
        """
        d2 = predictive_d2(
            xhat,
            P,
            np.ascontiguousarray(z[:, :2]),
            slots,
            self.n_slots,
            R,
            self.store.depth,
            self.store.roots,
            self.store.inner_child,
            self.store.leaf_mu,
            self.store.leaf_S,
        )
        unrepresentable = np.any(np.isinf(d2), axis=0)  # NaN: not mapped
        outlier = ~unrepresentable & (self.weights @ (d2 > self.gate_known) > 0.5)  # NaN compares False
        self.rejected["nonfinite"] += int(unrepresentable.sum())
        self.rejected["gate"] += int(outlier.sum())
        keep = ~(outlier | unrepresentable)
        return z[keep], slots[keep], R[keep]

    def _slot(self, landmark_id: int) -> int:
        if landmark_id not in self._slot_of_id:
            self._slot_of_id[landmark_id] = len(self._id_of_slot)
            self._id_of_slot.append(landmark_id)
        return self._slot_of_id[landmark_id]

    def _noise(self, z: np.ndarray) -> np.ndarray:
        """R of every row (k, 2, 2): the same R, or the Cartesian-isotropic form diag(σ², σ²/r²)
        (:func:`~slamarena.estimators.models.observation_covariances`)."""
        return np.ascontiguousarray(observation_covariances(self.R, z[:, 0], self.params.range_bearing_noise))

    def resample(self) -> np.ndarray:
        """Low-variance (systematic) resampling; returns the ancestors (M,)."""
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        pointers = self.rng.uniform(0.0, 1.0 / self.M) + np.arange(self.M) / self.M
        ancestors = np.searchsorted(cumulative, pointers, side="right").astype(np.int64)
        self._trace_ancestry(ancestors)
        self.x0 = self.x0[ancestors]
        self.n_slots = self.n_slots[ancestors]
        self.n_live = self.n_live[ancestors]
        self.store.resample(ancestors)
        self.log_w = np.zeros(self.M)
        self.resamplings += 1
        self.last_ancestors = ancestors
        return ancestors

    def _trace_ancestry(self, a: np.ndarray) -> None:
        """s ← s' for the non-decreasing ancestors a (M,) of a resampling (module docstring, "Ancestry"): O(M)."""
        split = np.full(a.size - 1, self._t)
        apart = np.flatnonzero(a[:-1] < a[1:])  # neighbours of different parents: the earliest split between them
        if apart.size:
            split[apart] = np.minimum.reduceat(self.split_t[: a[-1]], a[apart])
        self.split_t = split

    # ------------------------------------------------------------------ maps
    def landmarks(self, particle: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Live, confirmed landmarks of one particle (default: the heaviest): ids (L,), means (L, 2), covariances (L, 2, 2).

        Ids are the data's ids with known association, the particle's slot numbers otherwise."""
        m = int(np.argmax(self.log_w)) if particle is None else int(particle)
        mu, S, state, seen, _ = (a[0] for a in self.store.gather(int(self.n_slots[m]), particles=[m]))
        live = np.flatnonzero((state > 0) & (seen >= (1 if self.params.use_ids else self.params.confirm_sightings)))
        cov = np.stack([S[live, 0], S[live, 1], S[live, 1], S[live, 2]], axis=-1).reshape(-1, 2, 2)
        ids = np.asarray(self._id_of_slot, dtype=np.int64)[live] if self.params.use_ids else live.astype(np.int64)
        return ids, mu[live], cov

    def landmark_counts(self) -> np.ndarray:
        """Live landmarks of every particle (M,), tentative ones included, kept by the update (O(M))."""
        return self.n_live.copy()

    # ``run(sequence) -> Estimate`` is :func:`.run.run_sequence`, bound by the package (this module does not import its
    # runner)


def huber_tail(d: float, k: float) -> float:
    """P(‖e‖ > d) for a 2-D whitened innovation e of density ∝ exp(−ρ_k(‖e‖)) (Gaussian inside k, Laplace-like beyond):
    with the radial density d exp(−ρ_k(d)), whose integral is 1 − e^{−k²/2} inside k and e^{−k²/2}(1 + 1/k²) beyond,
    Z = 1 + e^{−k²/2} / k²; k = ∞ gives the χ²₂ tail e^{−d²/2}."""
    if d <= k:
        return (math.exp(-0.5 * d * d) - math.exp(-0.5 * k * k) + math.exp(-0.5 * k * k) * (1 + 1 / (k * k))) / (
            1 + math.exp(-0.5 * k * k) / (k * k)
        )
    return math.exp(0.5 * k * k - k * d) * (d / k + 1 / (k * k)) / (1 + math.exp(-0.5 * k * k) / (k * k))


def huber_gate(confidence: float, k: float) -> float:
    """The gate γ on d² with P(d² ≤ γ) = confidence under the Huber density of width k (:func:`huber_tail`); k = ∞: the
    χ²₂ quantile. The association's gate and, through p₀, the new-landmark density are the sensor model's own."""
    if math.isinf(k) or confidence == 1.0:
        return chi2_gate(confidence, 2)
    from scipy.optimize import brentq

    d = brentq(lambda d: huber_tail(d, k) - (1.0 - confidence), 0.0, 1e3, xtol=1e-12, rtol=1e-14)
    return d * d


def _sqrt_batch(P: np.ndarray) -> np.ndarray:
    """A square root of every PSD matrix of P (M, 3, 3)."""
    w, V = np.linalg.eigh(0.5 * (P + np.swapaxes(P, -1, -2)))
    return V * np.sqrt(np.clip(w, 0.0, None))[..., None, :]
