"""EKF-SLAM with a growing state, O(n) prediction and O(n²) updates.

Model
-----
Robot pose ``x_r = (x, y, θ)``, control ``u = (v, ω)`` held for ``dt``, static point landmarks
``m_i = (m_ix, m_iy)``. Motion ``x_r' = f(x_r, u, dt)`` is the Euler or the exact arc model of
:mod:`slamarena.estimators.models` (``MOTION_MODELS``); odometry increments ``δ`` move the robot by
``x_r' = x_r ⊕ δ``. Observations ``z = h(x_r, m_i) + η = [range, bearing] + η``,
``η ~ N(0, R)``.

State layout (N = 3 + 2n, growing as landmarks are discovered)::

    x = [x, y, θ, m0x, m0y, m1x, m1y, …]                          (N,)
    P = [[P_rr (3×3)   P_rm (3×2n) ],
         [P_mr (2n×3)  P_mm (2n×2n)]]                               (N, N)

Prediction (touches the robot block and the robot-landmark cross-covariances: O(n))::

    x_r ← f(x_r, u, dt)
    P_rr ← G P_rr Gᵀ + Q          G = ∂f/∂x_r (3×3)
    P_rm ← G P_rm ,  P_mr = P_rmᵀ  (3×2n)
    Q = V M Vᵀ  (control-space noise, V = ∂f/∂u 3×2, M = twist covariance 2×2),
    Q = (T / dt) V M Vᵀ with a stated row period T (``twist_period``: white velocity noise of density M T,
        estimators.models.twist_increment_cov, the convention FastSLAM shares)   or
    Q = Cx · dt (additive robot-block noise, Cx a 3×3 covariance per second)

This equals the dense ``P ← G_N P G_Nᵀ + F_xᵀ Q F_x`` with ``G_N = I_N + F_xᵀ (G − I₃) F_x``.
All motion here composes a body increment, ``G = I + [[0, 0, −D_y], [0, 0, D_x], 0]`` with D
the world-frame displacement, so a chain of K predictions (:meth:`EKFSLAM.predict_twists`,
:meth:`EKFSLAM.predict_increments`; ``run`` applies the motion between two observation sets
as one chain) needs the 3×3 recursion per piece but ``P_rm ← Φ P_rm`` only once, with
``Φ = I + [[0, 0, −ΣD_y], [0, 0, ΣD_x], 0]``.

Update with one observation of landmark i (state indices ``idx = [0, 1, 2, s, s+1]``,
``s = 3 + 2i``): H (2×N) has only the five columns ``idx`` non-zero,
``H[:, idx] = [H_x (2×3), H_m (2×2)]``, so::

    PHᵀ = P[:, idx] @ H[:, idx]ᵀ                                   (N×5 @ 5×2 = N×2), O(N)
    S   = H[:, idx] @ PHᵀ[idx] + R                                  (2×2), Cholesky-checked
    K   = PHᵀ S⁻¹        (2×2 solve, never an N×N inverse)          (N×2)
    ν   = z − h(x_r, m_i), bearing wrapped to (−π, π]               (2,)
    x  ← x + K ν ,  θ wrapped
    P  ← (I − KH) P = P − K (PHᵀ)ᵀ = P − W Wᵀ ,  W = PHᵀ L⁻ᵀ, S = L Lᵀ      standard, O(N²)
    P  ← (I − KH) P (I − KH)ᵀ + K R Kᵀ = P − K(PHᵀ)ᵀ − PHᵀKᵀ + K S Kᵀ       Joseph, O(N²)

Noise scales: every Q above is multiplied by ``q_scale`` and every R_j below by ``r_scale`` (both 1 unless ``run()``
without trusted ids, asked to (``self_identify``, off by default), finds that the innovations reject the stated noise:
:mod:`.self_identification`, which runs the sequence again with scaled noise and keeps the most likely run).

R is each row's own: the parameter's (``range_bearing_noise`` polar, or Cartesian ``diag(σ², σ²/r_j²)``), or the
``R`` given to :meth:`EKFSLAM.update` per row (``run`` passes the sequence's per-observation covariances). With
``robust_update`` ("huber", "student_t") a matched row is applied with ``R_j / w_j``, w_j the IRLS weight of its
posterior residual on the estimate before the set (:func:`slamarena.robust.kalman_weights`: Huber's M-estimate, or the
Student-t noise's variational fixed point); w = 1 is the update above.

The Joseph form is expanded with ``HP = (PHᵀ)ᵀ`` and ``HPHᵀ + R = S`` into rank-2d symmetric terms
(see ``_correct``); there is no N×N×N product and no N×N inverse anywhere. With
``update="batch"`` all matched observations of a set are stacked (H 2m×N, S 2m×2m) and applied
as one update with the same formulas.

Deferred covariance update (``defer_covariance=True``). Every update of a set is a symmetric
low-rank term, ``P_k = P_{k−1} + C_k diag(s_k) C_kᵀ`` (standard: ``C_k = W_k``, ``s = −1``), so after
k updates ``P_k = P_0 + U_k diag(s) U_kᵀ`` with ``U_k = [C_1 … C_k]`` (N × r). Update k+1 reads P only
through its five columns, ``P_k[:, idx] = P_0[:, idx] + U_k diag(s) U_k[idx, :]ᵀ`` (O(N r)), and its
checks only through O(N) entries (kept incrementally), so it is computed exactly as the
sequential filter computes it, and the N×N term ``U_m diag(s) U_mᵀ`` (rank 2m; Joseph 6m) is
applied once at the end of the set, in one pass over the lower triangle of P
(:mod:`.storage`, :mod:`.kernels`). A landmark created after k updates takes its
cross-covariance from the current robot rows ``P_k[0:3, :]``; its rows of U are zero (the earlier
terms are in its stored values, the later ones have non-zero rows for it), so every entry of
the final P is the sequential one. ``False``: the term is applied after every observation.

Within a run of matched rows the standard form does not even read the growing term per row: every W_i lies in the
span of the rows ``B_i = H_i P_0`` (2 × N), so ``P_{j−1} = P_0 − Bᵀ M B`` with a small symmetric M (2j × 2j) and row j
needs only the five entries idx_j of each earlier B_i (``S_j``, its gain's coefficients ``t_j`` in that span, and
``x_{j−1}[idx_j]`` where h and H_j are evaluated); the run's term ``U = Bᵀ T`` and ``dx = Bᵀ v`` are formed once at its
end (:func:`.kernels.correct_run` states the recursion). The covariance checks are then made once, on P_m: every
P_j = P_m + Σ_{i>j} W_i W_iᵀ passes them if P_m does; a run that fails them is redone row by row to find the row.

New landmark (inverse observation model ``m = g(x_r, z)``, ``G_x = ∂g/∂x_r`` 2×3,
``G_z = ∂g/∂z`` 2×2)::

    init="jacobian":  P_new,: = G_x P[0:3, :] ,  P_new,new = G_x P_rr G_xᵀ + G_z R G_zᵀ
    init="initP":     P_new,: = 0 ,              P_new,new = init_cov · I₂
                      (the matrix-dimensions reference: ignores the robot uncertainty and
                      the robot-landmark correlation, which makes the filter overconfident)

Linearisation points (``jacobians=``):

* ``"standard"``: every Jacobian at the current estimate.
* ``"fej"`` (first-estimates Jacobian EKF, Huang, Mourikis & Roumeliotis 2008): the motion
  Jacobian is ``G = I + [[0, 0, −(ŷ_{k+1|k} − ŷ_{k|k−1})], [0, 0, x̂_{k+1|k} − x̂_{k|k−1}], 0]``,
  i.e. the position difference uses the robot's *propagated* estimate ``x̂_{k|k−1}`` (the
  output of the previous prediction, before any update) instead of the updated ``x̂_{k|k}``
  (for Euler, arc and increment motion ``G = I + [0 0 −Δy; 0 0 Δx; 0 0 0]``); the
  measurement Jacobians ``H_x, H_m`` are evaluated at the robot's propagated estimate
  ``x̂_{k|k−1}`` and at the landmark's FIRST estimate (its value when initialised). The noise
  Jacobian V, the landmark-initialisation Jacobians and the predicted measurement ``h(x̂)``
  use the current estimate.
* ``"oc"`` (observability-constrained, Huang, Mourikis & Roumeliotis 2010): linearisation points (anchors) under the
  constraint that keeps the unobservable directions of the true system (global translation and rotation) unobservable
  in the linearised one: every landmark's anchor is fixed at initialisation (``m̆ = x̆ + (m̂ − x̂)``, so the
  initialisation Jacobian maps the robot's nullspace directions onto the landmark's), the robot's anchor x̆ moves with
  the propagation Jacobians, and before each update set it is shifted by the offset closest to the current estimates
  (least squares over the set's landmarks, :meth:`EKFSLAM._reanchor`).
* FEJ and OC both: a landmark's point is only as good as the pose it was first estimated from. Before each update set
  the measurement a matched landmark's points predict, ``z̆ = h(x̆, m̆)``, is gated as a measurement of it,
  ``d² = (z̆ − h(x̂, m̂))ᵀ S⁻¹ (z̆ − h(x̂, m̂)) > χ²₂(anchor_confidence)`` (S at the current estimate), and a point that
  fails is set again by its initialisation rule (:meth:`EKFSLAM._refresh_anchors`). Off by default
  (``anchor_confidence=None``, the published filters): it also fires after loop closures, where the posterior S is
  smaller than the prior a point was made under, and at 0.99999 that takes FEJ and OC out of the χ² band on a hard
  simulated world.
* ``"ideal"``: every Jacobian (G and V with the measured control, H, G_x, G_z) at the TRUE
  robot pose and TRUE landmark positions, given through :meth:`EKFSLAM.set_truth` (``run``
  supplies them from the sequence's ground truth). A diagnostic device of consistency
  studies, not an estimator.

Data association: rows with ``landmark_id ≥ 0`` (and ``use_ids=True``) by id; rows with id
−1 (or all rows when ``use_ids=False``) by Mahalanobis nearest neighbour or JCBB
(:mod:`.association`), decided on the estimate before the set is applied; with ``window`` > 0, ``run`` decides a row
that is ambiguous (:func:`.association.hypotheses`, :meth:`EKFSLAM.ambiguity`) by the sets that follow it and passes the
decision to :meth:`EKFSLAM.update` (``decide``). A labelled row of a
mapped landmark is χ²-gated too: applied only if ``d² = νᵀ S⁻¹ ν < χ²₂(known_confidence)``
(default 0.99999, so a true observation with the stated noise is rejected with probability
1e-5; an outlier of a real sensor is not applied). ``known_confidence=None`` removes the gate
(the notes' filter, for oracle comparisons); a row whose d² is not finite is still rejected.

Bad input (:mod:`slamarena.estimators.inputs`, shared with FastSLAM). Every step computes its result, checks it, and
only then changes the state, so a rejected or failing step leaves x and P exactly as they were:

* stamps: an update's t must be finite and not before the last update's, else ``ValueError``;
* observations: rows with a non-finite value or a negative range are rejected and counted; a row
  is also rejected (counted in ``rejected["nonfinite"]``) when its update is not representable —
  a non-finite d², gain step or covariance term, or a new landmark whose mean or covariance is
  not finite (e.g. a range of 1e200 m: ``G_z R G_zᵀ`` overflows);
* motion: ``dt <= 0``, a non-finite control or increment, or a chain whose predicted poses or
  covariances (``G P Gᵀ + Q``, ``Φ P_rm``) are not finite raise ``ValueError``. This is the
  definition of an absurd control: one whose prediction the model cannot represent (e.g.
  ``v = 1e300``: the step is finite but ``G P Gᵀ`` overflows), not a bound on speed;
* the covariance is checked in O(N) (:mod:`.checks`) before each step is committed; a loss of
  positive definiteness raises :class:`~.checks.CovarianceError` (``on_indefinite="record"``:
  counted in ``rejected["indefinite"]``; an observation is then skipped, a prediction applied).
"""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Literal

import numpy as np
from pydantic import FiniteFloat, PositiveFloat, model_validator

from slamarena.datasets.geometry import wrap_angle
from slamarena.params import Covariance2, Covariance3, Field, Params
from slamarena.robust import KalmanKernel, kalman_weights

from ..inputs import next_stamp, valid_rows
from ..kernels import twist_motion
from ..models import (
    ARC,
    DEFAULT_RANGE_BEARING_COV,
    MOTION_MODELS,
    UNSTATED_TWIST_COV,
    RangeBearingNoise,
    TwistPeriod,
    chi2_gate,
    inverse_observation_jacobians,
    inverse_observe,
    noise_in_force,
    observation_covariances,
    observe,
    twist_increment_cov,
)
from ..stepping import StepClock
from . import association as assoc
from .association import Decision
from .checks import CovarianceError, check_augmented, entries_error, innovation_cov_error
from .kernels import APPLIED, NOT_FINITE, ROBOT_INDEFINITE, S_INDEFINITE
from .storage import GrowingState

__all__ = [
    "EKFSLAM",
    "EKFSLAMParams",
    "CovarianceError",
    "MotionNoise",
    "RangeBearingNoise",
    "UpdateForm",
    "CovarianceUpdate",
    "LandmarkInit",
    "AssociationMethod",
    "Linearisation",
    "OnIndefinite",
    "UNSTATED_TWIST_COV",
    "DEFAULT_RANGE_BEARING_COV",
    "NEW_ID_BASE",
]

#: ids given to landmarks created from unlabelled rows while labelled ids are in use
NEW_ID_BASE = 1_000_000


class MotionNoise(StrEnum):
    """Prediction noise Q of the robot block."""

    CONTROL = "control"  # Q = V M Vᵀ, M the twist covariance
    ADDITIVE = "additive"  # Q = Cx · dt


class UpdateForm(StrEnum):
    """How the matched observations of one set are applied."""

    SEQUENTIAL = "sequential"  # one 2-row update per observation
    BATCH = "batch"  # one stacked 2m-row update


class CovarianceUpdate(StrEnum):
    """Form of the covariance update."""

    STANDARD = "standard"  # P ← (I − KH) P
    JOSEPH = "joseph"  # P ← (I − KH) P (I − KH)ᵀ + K R Kᵀ


class LandmarkInit(StrEnum):
    """Covariance of a new landmark."""

    JACOBIAN = "jacobian"  # propagated through the inverse observation model
    INIT_P = "initP"  # init_cov · I₂, uncorrelated (the matrix-dimensions reference)


class AssociationMethod(StrEnum):
    """Association of rows without a (trusted) landmark id."""

    NEAREST_NEIGHBOUR = "nn"
    JCBB = "jcbb"


class Linearisation(StrEnum):
    """Linearisation point of the Jacobians (the ``jacobians`` parameter; module docstring)."""

    STANDARD = "standard"  # the current estimate
    FEJ = "fej"  # first estimates
    OC = "oc"  # observability-constrained linearisation points (Huang et al. 2010)
    IDEAL = "ideal"  # the truth (set_truth)


class OnIndefinite(StrEnum):
    """What a loss of positive definiteness does."""

    RAISE = "raise"  # raise CovarianceError
    RECORD = "record"  # count it (rejected["indefinite"]); skip the observation (a prediction is applied)


#: a χ² gate's confidence, strictly inside (0, 1)
Confidence = Annotated[float, Field(gt=0.0, lt=1.0)]


class EKFSLAMParams(Params):
    """Parameters of :class:`EKFSLAM`."""

    motion_model: Literal["arc", "euler"] = Field(
        "arc",
        description="motion model of Twist input (estimators.models): exact constant-twist arc or the notes' Euler step",
    )
    motion_noise: MotionNoise = Field(
        MotionNoise.CONTROL,
        description="prediction noise: 'control' Q = V M Vᵀ (M = twist_cov), 'additive' Q = Cx·dt on the robot block",
    )
    twist_cov: Covariance2 | None = Field(
        None,
        description="M, covariance of the control (v, ω) [(m/s)², (rad/s)²]; None: the sequence's Noise.twist_cov, else UNSTATED_TWIST_COV "
        "(MRCLAM's identified noise)",
    )
    twist_period: TwistPeriod = None
    Cx: Covariance3 | None = Field(
        None,
        description="additive robot-block noise per second of (x, y, θ) [m²/s, m²/s, rad²/s]; required with motion_noise='additive'",
    )
    increment_cov: Covariance3 | None = Field(
        None,
        description="covariance of an odometry increment (dx, dy, dθ) [m², m², rad²], overriding Increments.cov; "
        "None: Increments.cov, else Noise.increment_cov",
    )
    range_bearing_cov: Covariance2 | None = Field(
        None,
        description="R, covariance of an observation (range, bearing) [m², rad²]; None: the sequence's Noise.range_bearing_cov, "
        "else DEFAULT_RANGE_BEARING_COV",
    )
    range_bearing_noise: RangeBearingNoise = Field(
        RangeBearingNoise.POLAR,
        description="'polar': R for every observation; 'cartesian': the sensor noise is isotropic σ² I in "
        "Cartesian coordinates (as Victoria Park states it), R_j = diag(σ², σ²/r_j²) with σ² = R[0, 0] [m²] and r_j the range [m]",
    )
    update: UpdateForm = Field(
        UpdateForm.SEQUENTIAL,
        description="'sequential': one update per matched observation; 'batch': one stacked update per observation set",
    )
    defer_covariance: bool = Field(
        True,
        description="apply the N×N covariance update of an observation set once, at its end (rank 2m, one pass over P; the same "
        "result as applying it per observation, up to rounding); False: one pass over P per observation",
    )
    covariance_update: CovarianceUpdate = Field(
        CovarianceUpdate.STANDARD, description="'standard' (I − KH) P or 'joseph' (I − KH) P (I − KH)ᵀ + K R Kᵀ"
    )
    init: LandmarkInit = Field(
        LandmarkInit.JACOBIAN,
        description="new-landmark covariance: 'jacobian' through the inverse observation model, 'initP' init_cov · I₂ uncorrelated",
    )
    init_cov: float = Field(
        1.0,
        gt=0.0,
        allow_inf_nan=False,
        description="variance of each coordinate of a new landmark with init='initP' [m²]",
    )
    association: AssociationMethod = Field(
        AssociationMethod.NEAREST_NEIGHBOUR,
        description="association of rows without a trusted id: 'nn' Mahalanobis nearest neighbour or 'jcbb'",
    )
    use_ids: bool = Field(
        True, description="trust the landmark ids of the data (False: associate every row by `association`)"
    )
    match_confidence: Confidence = Field(0.95, description="χ²₂ gate of a match (d² below its quantile)")
    new_confidence: Confidence = Field(
        0.99999,
        description="χ²₂ gate beyond which an unmatched row starts a landmark (between the gates: rejected as ambiguous); "
        "at 0.99999 a true re-observation lands beyond it with probability 1e-5",
    )
    jcbb_confidence: Confidence = Field(0.95, description="χ²_2k gate of a joint hypothesis of k pairings in JCBB")
    known_confidence: Confidence | None = Field(
        0.99999,
        description="χ²₂ gate of a labelled row of a mapped landmark: beyond χ²₂(known_confidence) it is rejected as an outlier "
        "(at 0.99999 a true observation with the stated noise is rejected with probability 1e-5); "
        "None: no gate, every labelled row with a finite d² is applied (as in the notes; oracle comparisons)",
    )
    confirm_sightings: int = Field(
        1,
        ge=1,
        description="a landmark created from a row without a trusted id stays tentative until seen this many times (the creating "
        "sighting included) within confirm_window; 1: confirmed at once (association.LandmarkBook)",
    )
    confirm_window: float = Field(
        np.inf,
        gt=0.0,
        description="time [s] a tentative landmark has to reach confirm_sightings; removed (marginalised) after it",
    )
    miss_limit: int | None = Field(
        None,
        ge=0,
        description="quality counter (Dissanayake et al. 2001): a landmark created from a row without a trusted id is removed when "
        "its matches minus its misses (sets in which it is predicted in the sensor's field and not matched) fall below "
        "−miss_limit; None: never; needs sensor_range",
    )
    sensor_range: float | None = Field(
        None,
        gt=0.0,
        description="largest range at which the sensor detects a landmark [m] (the quality counter's field)",
    )
    sensor_fov: float = Field(
        2 * np.pi,
        gt=0.0,
        le=2 * np.pi,
        description="the sensor's field of view, centred ahead [rad] (the quality counter's field)",
    )
    window: int = Field(
        20,
        ge=0,
        description="look-ahead of an ambiguous row without a trusted id [observation sets]: its hypotheses (landmarks, or not in "
        "the map) are each run through the next `window` sets and the one that explains them best is applied "
        "(association.hypotheses; run() only); 0: every row decided on its own set. Default 20: Victoria Park's working "
        "configuration (chosen there; no row is ambiguous on the car park, labelled rows never are)",
    )
    window_hypotheses: int = Field(
        3,
        ge=1,
        description="most landmarks an ambiguous row is tried against (the most probable inside the match gate)",
    )
    robust_update: KalmanKernel = Field(
        "none",
        description="measurement update of a matched row: 'none' Gaussian; 'huber' or 'student_t' — the row applied with noise "
        "R / w, w the IRLS weight of its posterior residual (slamarena.robust.kalman_weights), decided on the estimate before "
        "the set as the association is",
    )
    robust_k: PositiveFloat = Field(
        2.4477,
        description="Huber width [σ of the whitened 2-vector residual]; default √χ²₂(0.95): a row whose posterior residual "
        "lies inside it is applied as by the Gaussian update",
    )
    robust_dof: PositiveFloat = Field(5.0, description="degrees of freedom ν of the Student-t measurement noise")
    self_identify: bool = Field(
        False,
        description="run() without trusted ids (use_ids=False): when the matched rows' NIS reject the stated noise (a median "
        "test at noise_confidence), the scales q of the process noise Q and r of the measurement noise R are searched on "
        "the grid noise_factor^{−noise_steps … noise_steps} by the run's own log-likelihood (coordinate line search), and "
        "the best is kept if it beats the stated model by the χ²₂(noise_confidence) likelihood-ratio test "
        "(self_identification; research/method/ekf_slam_adaptive_noise.md); False (default: on the car park the most likely "
        "scales map 81 landmarks for 15 beacons, research/notebook/2026-11-28-ekf-adaptive-noise.md): the stated noise as it is",
    )
    noise_factor: float = Field(4.0, gt=1.0, allow_inf_nan=False, description="step of the noise-scale grid")
    noise_steps: int = Field(
        3, ge=0, description="the grid's steps each way from the stated noise (q, r in factor^±steps)"
    )
    noise_confidence: Confidence = Field(
        0.99999,
        description="confidence of self_identify's tests: the stated noise is rejected, and a scaled one taken, only at it",
    )
    per_observation_cov: bool = Field(
        True,
        description="run(): when range_bearing_cov is not given and the sequence states a covariance per observation "
        "(meta['range_bearing_cov_per_observation'], e.g. the landmark extractor's), each row is updated with its own R_j",
    )
    anchor_confidence: Confidence | None = Field(
        None,
        description="FEJ / OC: a matched landmark whose linearisation point (with the robot's) predicts a measurement beyond "
        "χ²₂(anchor_confidence) of the current estimate's — d² against the innovation covariance S, as a measurement is "
        "gated — has its point set again by the rule that set it at initialisation (a stale first estimate); "
        "None (default): never, the published FEJ / OC-EKF (at 0.99999 the simulator's hard world leaves the χ² band: "
        "research/notebook/2026-11-28-landmark-real-data.md)",
    )
    jacobians: Linearisation = Field(
        Linearisation.STANDARD,
        description="linearisation point: 'standard' current estimate, 'fej' first estimates, "
        "'oc' observability-constrained (closest to the current estimates), 'ideal' the truth (diagnostic)",
    )
    initial_pose: tuple[FiniteFloat, FiniteFloat, FiniteFloat] | None = Field(
        None, description="start pose (x [m], y [m], θ [rad]); None: the sequence's start pose, else the origin"
    )
    initial_cov: Covariance3 = Field(
        0.0, description="covariance of the start pose (x, y, θ) [m², m², rad²]; 0: the start defines the frame"
    )
    on_indefinite: OnIndefinite = Field(
        OnIndefinite.RAISE,
        description="on a loss of positive definiteness: 'raise' CovarianceError (the state unchanged) "
        "or 'record' (count it; skip the observation, apply the prediction)",
    )
    capacity: int = Field(
        64, ge=3, description="initial capacity of the state buffers [state entries]; doubled when full"
    )
    step_clock: StepClock = Field(
        "wall", description="clock of run()'s step_time: wall time, or the process's CPU time (all threads) [s]"
    )

    @model_validator(mode="after")
    def _rules(self) -> EKFSLAMParams:
        if self.motion_noise == MotionNoise.ADDITIVE and self.Cx is None:
            raise ValueError("motion_noise='additive' needs Cx (3×3 covariance per second)")
        if self.new_confidence < self.match_confidence:
            raise ValueError(
                "new_confidence must be >= match_confidence (the new-landmark gate lies beyond the match gate)"
            )
        if self.miss_limit is not None and self.sensor_range is None:
            raise ValueError("miss_limit needs sensor_range (the field in which a landmark is predicted visible)")
        if self.jacobians == Linearisation.IDEAL and not self.use_ids:
            raise ValueError(
                "jacobians='ideal' needs use_ids=True (the true landmarks are looked up by the data's ids)"
            )
        return self


#: absurd inputs overflow to inf/NaN inside a step; the step checks its result before the state changes
_OVERFLOW_IS_CHECKED = np.errstate(over="ignore", invalid="ignore")
_NEW, _MATCHED, _REJECTED = int(Decision.NEW), int(Decision.MATCHED), int(Decision.REJECTED)
_NONE, _NONE_3, _NONE_33 = (
    np.zeros(0),
    np.zeros((0, 3)),
    np.zeros((0, 3, 3)),
)  # an argument of a compiled call not given


def _matrix(value) -> np.ndarray | None:
    return None if value is None else np.asarray(value, dtype=float)


class EKFSLAM:
    """EKF-SLAM (see the module docstring for model, layout and equations; parameters: :class:`EKFSLAMParams`)."""

    Params = EKFSLAMParams

    def __init__(self, params: EKFSLAMParams | None = None, /, **overrides):
        self.params = p = self.Params.of(params, overrides)
        self.model = MOTION_MODELS[p.motion_model]
        self._twist_cov = _matrix(p.twist_cov)
        self._Cx = _matrix(p.Cx)
        self._increment_cov = _matrix(p.increment_cov)
        self._range_bearing_cov = _matrix(p.range_bearing_cov)
        self._initial_pose = _matrix(p.initial_pose)
        self._initial_cov = _matrix(p.initial_cov)
        self.gate_match = chi2_gate(p.match_confidence, 2)
        self.gate_new = chi2_gate(p.new_confidence, 2)
        self.gate_known = chi2_gate(p.known_confidence, 2)
        self.gate_anchor = chi2_gate(p.anchor_confidence, 2)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, sequence=None) -> None:
        """Start over at the initial pose (of the parameters, else of ``sequence``), noise resolved."""
        self.q_scale = self.r_scale = 1.0  # Q → q_scale · Q, R → r_scale · R (self_identification sets them per run)
        self.M = noise_in_force(self._twist_cov, sequence, "twist_cov", UNSTATED_TWIST_COV)
        self.R = noise_in_force(self._range_bearing_cov, sequence, "range_bearing_cov", DEFAULT_RANGE_BEARING_COV)
        self.increment_cov = noise_in_force(self._increment_cov, sequence, "increment_cov")
        pose = (
            self._initial_pose
            if self._initial_pose is not None
            else (sequence.start_pose if sequence is not None else np.zeros(3))
        )
        self._s = GrowingState(3, self.params.capacity)
        self._s.x[:] = pose
        self._s.x[2] = wrap_angle(pose[2])
        self._s.P[:] = self._initial_cov
        self._ids: list[int] = []
        self._slot: dict[int, int] = {}
        self._first = np.zeros((8, 2))  # landmark linearisation points: first estimates (FEJ), anchors (OC)
        self._robot_prior = self._s.x[:3].copy()  # the robot's: the propagated estimate (FEJ), its anchor (OC)
        self._carry: np.ndarray | None = (
            None  # OC: the robot anchor's offset from the estimate after the last update set
        )
        self._truth_pose: np.ndarray | None = None
        self._truth_landmarks: dict[int, np.ndarray] = {}
        self._next_id = NEW_ID_BASE if self.params.use_ids else 0
        p = self.params
        self.book = assoc.LandmarkBook(
            p.confirm_sightings, p.confirm_window, p.miss_limit, p.sensor_range, p.sensor_fov
        )
        self._sets, self._t = 0, None  # the number of update sets and the last one's stamp
        self.rejected = {"nonfinite": 0, "negative_range": 0, "indefinite": 0, "covariance": 0}
        self.anchors_reset = 0  # FEJ / OC: landmark linearisation points set again (anchor_confidence)
        self.nis_log: list[tuple[float, int]] = []
        self.assoc_log: list[tuple[int, int, float, int]] = []
        self.weight_log: list[
            float
        ] = []  # per logged row: the robust weight of a matched row (1 without), NaN if not matched
        self.log_likelihood = 0.0  # Σ log λ of the rows associated without an id (association.hypotheses)

    @property
    def x(self) -> np.ndarray:
        """State estimate (N,), read-only view."""
        v = self._s.x.view()
        v.flags.writeable = False
        return v

    @property
    def P(self) -> np.ndarray:
        """State covariance (N, N), read-only view (the first read after an update copies its upper triangle, O(N²): :mod:`.storage`)."""
        v = self._s.P.view()
        v.flags.writeable = False
        return v

    @property
    def robot_cov(self) -> np.ndarray:
        """Robot covariance P[0:3, 0:3] (3, 3), a copy, O(1)."""
        return self._s.view[:3, :3].copy()

    @property
    def landmark_ids(self) -> np.ndarray:
        """Id of each landmark slot (n,), in state order."""
        return np.asarray(self._ids, dtype=np.int64)

    @property
    def n_landmarks(self) -> int:
        return len(self._ids)

    @property
    def confirmed(self) -> np.ndarray:
        """Whether each landmark slot (n,) is confirmed (not tentative; association.LandmarkBook)."""
        return self.book.confirmed

    def set_truth(self, pose=None, landmarks=None) -> None:
        """True robot pose (3,) and/or true landmarks ({id: (x, y)} or a LandmarkMap) for jacobians="ideal"."""
        if pose is not None:
            self._truth_pose = np.array(pose, dtype=float).reshape(
                3
            )  # a copy: a view of x would move with the estimate
        if landmarks is not None:
            if hasattr(landmarks, "ids"):
                landmarks = dict(zip(landmarks.ids.tolist(), landmarks.xy))
            self._truth_landmarks = {int(k): np.array(v, dtype=float).reshape(2) for k, v in landmarks.items()}

    # ------------------------------------------------------------------ prediction
    def predict(self, u, dt: float) -> None:
        """Propagate with control u = [v, yaw_rate] held for dt > 0 (O(n))."""
        u = np.asarray(u, dtype=float).reshape(2)
        self.predict_twists(u[:1], u[1:], np.array([dt], dtype=float))

    @_OVERFLOW_IS_CHECKED
    def predict_twists(self, v, omega, dt, true_poses=None) -> tuple[np.ndarray, np.ndarray]:
        """A chain of K predictions with (v_k, ω_k) held for dt_k; returns the K robot poses and 3×3 covariances.

        ``true_poses`` (K, 3): the true pose at the start of each piece (jacobians="ideal").
        """
        v, omega, dt = (np.asarray(a, dtype=float).reshape(-1) for a in (v, omega, dt))
        if not np.all(np.isfinite(dt) & (dt > 0)):
            raise ValueError(f"dt must be finite and > 0, got {dt[~(np.isfinite(dt) & (dt > 0))][:3].tolist()}")
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(omega))):
            raise ValueError("controls must be finite")
        delta, Q_body = twist_motion(v, omega, dt, self.model is ARC, self.M)  # δ (K, 3), V M Vᵀ (K, 3, 3)
        if self.params.motion_noise == MotionNoise.ADDITIVE:
            return self._chain(delta, None, self._Cx[None] * dt[:, None, None], true_poses)
        return self._chain(delta, twist_increment_cov(Q_body, dt, self.params.twist_period), None, true_poses)

    def predict_increment(self, delta, cov=None) -> None:
        """Propagate with a body-frame odometry increment δ = (dx, dy, dθ) of covariance cov (3×3)."""
        self.predict_increments(
            np.asarray(delta, dtype=float).reshape(1, 3),
            None if cov is None else np.asarray(cov, dtype=float).reshape(1, 3, 3),
        )

    @_OVERFLOW_IS_CHECKED
    def predict_increments(self, delta, cov=None, true_poses=None) -> tuple[np.ndarray, np.ndarray]:
        """A chain of K odometry increments (K, 3) with covariances (K, 3, 3) (default: increment_cov)."""
        delta = np.asarray(delta, dtype=float).reshape(-1, 3)
        if not np.all(np.isfinite(delta)):
            raise ValueError("odometry increments must be finite")
        if cov is None:
            if self.increment_cov is None:
                raise ValueError(
                    "an odometry increment needs a covariance (Increments.cov, Noise.increment_cov or increment_cov=)"
                )
            cov = np.broadcast_to(self.increment_cov, (len(delta), 3, 3))
        return self._chain(delta, np.asarray(cov, dtype=float).reshape(-1, 3, 3), None, true_poses)

    def _chain(self, delta, Q_body, Q_world, true_poses, anchor_shift=None) -> tuple[np.ndarray, np.ndarray]:
        """x_r ← x_r ⊕ δ_0 ⊕ … ⊕ δ_{K−1}, robot block by the 3×3 recursion, P_rm ← Φ P_rm once.

        Every motion here is "compose with a body increment", so ``G_k = I + [[0, 0, −D_y], [0, 0, D_x], 0]``
        with D_k the world-frame displacement at the linearisation point, and the product of
        the chain is ``Φ = I + [[0, 0, −ΣD_y], [0, 0, ΣD_x], 0]`` (the correction terms commute).
        Noise: ``Q_k = q_scale · Rot(θ_k) Q_body,k Rot(θ_k)ᵀ`` (Rot = blockdiag(R(θ), 1)) or ``q_scale · Q_world,k``.

        With ``jacobians="fej"`` or ``"oc"`` the first piece starts at the robot's linearisation point
        (``D_0 = x̂_1 − x̆``, x̆ = ``_robot_prior``), so that the points are continuous along the chain;
        ``anchor_shift`` (OC only, :meth:`_reanchor`) ends the chain that much beyond the estimate
        (``D_{K−1} += shift``, the linearisation point becomes ``x̂_K + shift``).

        The whole result is computed and checked before the state changes: a chain whose poses, robot
        covariances or cross-covariances are not finite raises ``ValueError``, one whose robot covariance
        is indefinite raises :class:`CovarianceError` (``on_indefinite="record"``: counted and applied).
        """
        if len(delta) == 0:
            return np.zeros((0, 3)), np.zeros((0, 3, 3))
        if self.params.jacobians == Linearisation.IDEAL:
            lin = (
                np.broadcast_to(self._linearisation_pose(), (len(delta), 3))
                if true_poses is None
                else np.asarray(true_poses, dtype=float).reshape(-1, 3)
            )
        else:
            lin = _NONE_3  # the chain's own poses
        anchored = self.params.jacobians in (Linearisation.FEJ, Linearisation.OC)
        if (
            anchored and anchor_shift is None and self._carry is None
        ):  # OC: the anchor's offset after the last update set
            self._carry = self._robot_prior[:2] - self._s.x[:2]
        record = self.params.on_indefinite == OnIndefinite.RECORD
        poses, covs, _, outcome, k = (
            self._s.predict_chain(  # the robot rows and columns, all it reads and writes, are current
                np.ascontiguousarray(delta, dtype=float),
                np.ascontiguousarray(lin, dtype=float),
                self.q_scale * np.array(Q_body, dtype=float) if Q_world is None else _NONE_33,
                _NONE_33 if Q_world is None else self.q_scale * np.ascontiguousarray(Q_world, dtype=float),
                self._robot_prior[:2].copy() if anchored else _NONE,
                _NONE if anchor_shift is None else np.asarray(anchor_shift, dtype=float),
                record,
            )
        )
        if outcome == NOT_FINITE:
            raise ValueError(
                f"prediction {k} of {len(delta)} gives a non-finite pose or covariance (the motion or its covariance "
                "is beyond what the model can represent); the state is unchanged"
            )
        if outcome == ROBOT_INDEFINITE:  # "raise": nothing was committed; "record": committed, and counted here
            self._indefinite(CovarianceError("robot covariance lost positive semi-definiteness during prediction"))
        self._robot_prior = poses[-1].copy()
        if anchor_shift is not None:
            self._robot_prior[:2] += anchor_shift
        return poses[1:], covs

    def _reanchor(self, slots: np.ndarray) -> None:
        """OC: choose the robot's linearisation point for an update set observing landmark slots (k,), under the constraint.

        The constraint fixes every landmark's anchor m̆_i and lets the robot's anchor x̆ move only through
        the propagation Jacobians. With c = x̆ − x̂ (x̂ the current estimate), the anchor error of the
        propagation since the last update set is c − c' (c' the offset the last set left), the error of the
        relative vector of landmark i is (m̆_i − x̆) − (m̂_i − x̂) = e_i − c, e_i = m̆_i − m̂_i; the OC choice
        minimises their squared sum, ``c = (c' + Σ_i e_i) / (1 + k)``, and is applied as a noise-free
        zero-motion prediction whose Jacobian carries the shift (O(N), like any prediction).
        """
        x = self._s.x
        carry = self._robot_prior[:2] - x[:2] if self._carry is None else self._carry
        e = self._first[slots] - self._landmarks()[slots]
        c = (carry + e.sum(axis=0)) / (1 + len(slots))
        self._chain(np.zeros((1, 3)), np.zeros((1, 3, 3)), None, None, anchor_shift=c)
        self._carry = None

    def _refresh_anchors(self, slots: np.ndarray, R: np.ndarray) -> None:
        """FEJ / OC: set again the linearisation point m̆_i of every landmark slot (k,) (observed with noise R (k, 2, 2))
        that is no longer a state the filter holds plausible.

        The test treats the measurement the linearisation points predict, z̆_i = h(x̆, m̆_i) (x̆ the robot's point before
        the set), as a measurement of landmark i and gates it as one: d² = (z̆_i − h(x̂, m̂_i))ᵀ S_i⁻¹ (…) with
        S_i = H_i P H_iᵀ + R_i at the current estimate (:func:`.association.pair_d2`). Beyond χ²₂(anchor_confidence) the
        Jacobians taken there point elsewhere than the geometry the estimate holds (a first estimate made from a pose the
        filter has since corrected by more than its uncertainty), and an update through them moves the state along the
        wrong directions while its innovations stay small; the point is set by the rule of :meth:`_add_landmark`
        (FEJ: m̆ = m̂; OC: m̆ = x̆ + (m̂ − x̂)), counted in ``anchors_reset``. A landmark whose point passes keeps it, so
        on data its points describe the filter is the published FEJ / OC-EKF.
        """
        if slots.size == 0 or not np.isfinite(self.gate_anchor):
            return
        x = self._s.x
        predicted = observe(self._robot_prior, self._first[slots])
        try:
            d2 = assoc.pair_d2(x, self._s.view, R, predicted, slots)
        except CovarianceError:  # an S that is not positive definite: the set's own gating reports it
            return
        stale = np.unique(slots[d2 > self.gate_anchor])
        if stale.size:
            offset = self._robot_prior[:2] - x[:2] if self.params.jacobians == Linearisation.OC else 0.0
            self._first[stale] = self._landmarks()[stale] + offset
            self.anchors_reset += int(stale.size)

    def _linearisation_pose(self) -> np.ndarray:
        if self.params.jacobians == Linearisation.IDEAL:
            if self._truth_pose is None:
                raise ValueError("jacobians='ideal' needs the true pose: call set_truth(pose=...)")
            return self._truth_pose
        return self._s.x[:3]

    # ------------------------------------------------------------------ update
    @_OVERFLOW_IS_CHECKED
    def update(
        self, z, t: float | None = None, decide: dict[int, int] | None = None, R: np.ndarray | None = None
    ) -> None:
        """Apply an observation set z (M, 3) = [range, bearing, landmark_id] (id −1: unknown) taken at time t [s]
        (None: the number of sets so far; the landmark management's clock). ``decide``: {row of the valid rows: landmark
        slot, or −1 for a new landmark}, decisions made elsewhere for rows associated without an id (:meth:`ambiguity`).
        ``R`` (M, 2, 2): each row's own noise covariance (None: :meth:`observation_cov`).

        Rows with a non-finite value or a negative range are counted and dropped, as are rows whose own R is not a finite
        positive definite matrix (``rejected["covariance"]``). Every other row gets a
        decision (``assoc_log``, decided on the estimate before the set); a row that is not applied —
        ambiguous, outside a gate, or whose update would not be finite (counted in ``rejected["nonfinite"]``)
        or would make P indefinite (``on_indefinite="record"``) — is logged as rejected and changes nothing.
        With ``robust_update`` a matched row is applied with R_j / w_j (:meth:`_robust_weights`; ``weight_log``).
        """
        t = next_stamp(self._sets + 1 if t is None else t, self._t)
        z, Rz = self._valid(z, R)
        self._sets += 1
        self._t = t
        if not len(z):
            return
        counting = self.book.miss_limit is not None  # the quality counter is on
        predicted = observe(self._s.x[:3], self._landmarks()) if counting else None  # (n, 2), for the quality counter
        given = z[:, 2].astype(np.int64)
        ids = given if self.params.use_ids else np.full(len(z), -1)
        decision, slot, d2 = self._associate(z[:, :2], ids, Rz, decide or {})
        if self.params.jacobians in (Linearisation.FEJ, Linearisation.OC):
            matched = decision == _MATCHED
            self._refresh_anchors(slot[matched], Rz[matched])
        if self.params.jacobians == Linearisation.OC:
            self._reanchor(slot[decision == _MATCHED])
        weight = self._robust_weights(z[:, :2], Rz, decision, slot)
        try:
            self._apply(z, ids, Rz / weight[:, None, None], decision, slot)
        finally:  # the deferred covariance update of what was applied, also when a CovarianceError is raised
            self._s.flush()
        landmark = [self._ids[s] if s >= 0 else -1 for s in slot.tolist()]
        self.assoc_log.extend(zip(decision.tolist(), landmark, d2.tolist(), given.tolist()))
        self.weight_log.extend(np.where(decision == _MATCHED, weight, np.nan).tolist())
        if counting:
            predicted = np.concatenate([predicted, np.full((self.n_landmarks - len(predicted), 2), np.nan)])
        gone = self.book.observe(t, slot[decision == _MATCHED], predicted)
        if gone.size:
            self._remove_landmarks(gone)

    def _valid(self, z, R: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The rows of z (M, 3) that are finite with a non-negative range and, when their own covariances R (M, 2, 2) are
        given, a finite symmetric positive definite R_j; those rows and their R (k, 2, 2). The others are counted."""
        rows, finite, negative = valid_rows(z)
        self.rejected["nonfinite"] += int((~finite).sum())
        self.rejected["negative_range"] += int(negative.sum())
        if R is None:
            return rows, self.r_scale * self.observation_cov(rows)
        R = np.asarray(R, dtype=float)
        if R.shape != (len(finite), 2, 2):
            raise ValueError(f"R must hold one 2 × 2 covariance per row of z ({len(finite)}, 2, 2), got {R.shape}")
        R = R[finite & ~negative]
        with np.errstate(invalid="ignore", over="ignore"):
            scale = np.sqrt(np.abs(R[:, 0, 0] * R[:, 1, 1]))
            ok = (
                np.isfinite(R).all(axis=(1, 2))
                & (np.abs(R[:, 0, 1] - R[:, 1, 0]) <= 1e-9 * scale)  # symmetric up to the rounding of J Σ Jᵀ
                & (R[:, 0, 0] > 0)
                & (R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0] > 0)
            )
        R = 0.5 * (R + R.transpose(0, 2, 1))
        self.rejected["covariance"] += int((~ok).sum())
        return rows[ok], self.r_scale * R[ok]

    def _robust_weights(self, z: np.ndarray, Rz: np.ndarray, decision: np.ndarray, slot: np.ndarray) -> np.ndarray:
        """The weight w_j (M,) each row's R_j is divided by: 1, and with ``robust_update`` the matched rows' IRLS weights
        (:func:`slamarena.robust.kalman_weights`) from ν_j = z_j − h(x̂, m̂_i) and A_j = H_j P H_jᵀ on the estimate before
        the set (each row as if updated alone)."""
        weight = np.ones(len(z))
        matched = np.flatnonzero(decision == _MATCHED)
        if self.params.robust_update == "none" or not matched.size:
            return weight
        zhat, A = assoc.innovation_cov(self._s.x, self._s.view, slot[matched])
        nu = z[matched] - zhat
        nu[:, 1] = wrap_angle(nu[:, 1])
        p = self.params
        weight[matched] = kalman_weights(nu, A, Rz[matched], p.robust_update, p.robust_k, p.robust_dof)
        return weight

    def _apply(self, z: np.ndarray, ids: np.ndarray, Rz: np.ndarray, decision: np.ndarray, slot: np.ndarray) -> None:
        """Apply the rows of a set in order (batch: the matched ones first, stacked); rows not applied are marked rejected.

        The covariance updates are deferred (:mod:`.storage`): each reads the columns of P it needs,
        ``P_{k−1}[:, idx] = P_0[:, idx] − U_{k−1} U_{k−1}[idx, :]ᵀ``, and :meth:`update` applies
        ``P_m = P_0 − U_m U_mᵀ`` once (``defer_covariance=False``: after every row).
        """
        if self.params.update == UpdateForm.BATCH:
            matched = np.flatnonzero(decision == _MATCHED)
            if matched.size and not self._update_batch(slot[matched], z[matched, :2], Rz[matched]):
                decision[matched], slot[matched] = _REJECTED, -1
            pending = np.flatnonzero(decision == _NEW)
        else:
            pending = np.flatnonzero(decision != _REJECTED)
        dec, slots, labels, order = decision.tolist(), slot.tolist(), ids.tolist(), pending.tolist()  # Python scalars
        i = 0
        while i < len(order):
            j = order[i]
            if dec[j] == _NEW and labels[j] >= 0 and labels[j] in self._slot:  # id first seen earlier in this set
                dec[j], slots[j] = _MATCHED, self._slot[labels[j]]
            if dec[j] != _MATCHED:
                slots[j] = self._add_landmark(z[j, :2], labels[j] if labels[j] >= 0 else None, Rz[j])
                if slots[j] < 0:
                    dec[j] = _REJECTED
                i += 1
                continue
            run = [j]  # the consecutive matched rows, one compiled call (one row when each update is flushed at once)
            while self.params.defer_covariance and i + len(run) < len(order) and dec[order[i + len(run)]] == _MATCHED:
                run.append(order[i + len(run)])
            applied = self._update_run(np.array([slots[k] for k in run]), z[run, :2], Rz[run])
            if applied < len(run):
                dec[run[applied]], slots[run[applied]] = _REJECTED, -1
            i += min(applied + 1, len(run))
        decision[:], slot[:] = dec, slots

    def _remove_landmarks(self, slots: np.ndarray) -> None:
        """Marginalise landmark slots out of x and P (landmark management); the other slots keep their order."""
        self._s.remove(np.ravel(3 + 2 * slots[:, None] + np.arange(2)))
        keep = np.setdiff1d(np.arange(self.n_landmarks), slots)
        self._first = np.concatenate([self._first[keep], np.zeros((len(slots), 2))])
        self._ids = [self._ids[k] for k in keep]
        self._slot = {i: k for k, i in enumerate(self._ids)}
        self.book.remove(slots)

    def observation_cov(self, z: np.ndarray) -> np.ndarray:
        """R_j (M, 2, 2) of observations z (M, ≥1): R, or diag(σ², σ²/r_j²) for Cartesian sensor noise σ² = R[0, 0]
        (:func:`~slamarena.estimators.models.observation_covariances`)."""
        return observation_covariances(self.R, z[:, 0], self.params.range_bearing_noise)

    def ambiguity(
        self, z, decided: dict[int, int] | None = None, R: np.ndarray | None = None
    ) -> tuple[int, np.ndarray] | None:
        """The first row of set z (M, 3) (an index into its valid rows, as :meth:`update` numbers them) associated without an
        id that is ambiguous on the current estimate, and its hypotheses (landmark slots, −1: not in the map), or None
        (association.hypotheses); rows in ``decided`` are not asked about; ``R`` as in :meth:`update`. The state and the
        counts are not changed."""
        rejected = dict(self.rejected)
        z, Rz = self._valid(z, R)
        self.rejected = rejected
        unknown = np.flatnonzero(np.full(len(z), not self.params.use_ids) | (z[:, 2] < 0))
        unknown = unknown[~np.isin(unknown, list(decided or ()))]
        if not unknown.size or not self.n_landmarks:
            return None
        Rz = Rz[unknown]
        _, S, d2 = assoc.compatibility(self._s.x, self._s.view, Rz, z[unknown, :2])
        found = assoc.hypotheses(
            *assoc.log_densities(S, d2, Rz, self.gate_new),
            d2,
            self.gate_match,
            self.params.match_confidence,
            self.params.window_hypotheses,
        )
        return None if found is None else (int(unknown[found[0]]), found[1])

    def _associate(
        self, z: np.ndarray, ids: np.ndarray, Rz: np.ndarray, decide: dict[int, int]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        M = len(z)
        decision = np.full(M, _NEW, dtype=np.int8)
        slot = np.full(M, -1)
        d2 = np.full(M, np.nan)
        known = ids >= 0
        for j in np.flatnonzero(known):
            s = self._slot.get(int(ids[j]), -1)
            if s >= 0:
                decision[j], slot[j] = _MATCHED, s
        labelled = np.flatnonzero(slot >= 0)
        try:
            d2[labelled] = assoc.pair_d2(self._s.x, self._s.view, Rz[labelled], z[labelled], slot[labelled])
            self.rejected["nonfinite"] += int((~np.isfinite(d2[labelled])).sum())
        except (
            CovarianceError
        ) as exc:  # an S that is not positive definite; "record": the labelled rows of the set are skipped
            self._indefinite(exc, labelled.size)
        outside = labelled[
            ~(d2[labelled] < self.gate_known)
        ]  # gate_known = ∞ without a gate: only a non-finite d² is outside
        decision[outside], slot[outside] = _REJECTED, -1
        unknown = np.flatnonzero(~known)
        if unknown.size:
            # pair_d2 and compatibility read the robot rows and the landmarks' 2 × 2 blocks, current in the stored P;
            # JCBB reads landmark-landmark blocks too, from the whole P
            x = self._s.x
            nu, S, dist = assoc.compatibility(x, self._s.view, Rz[unknown], z[unknown])
            if self.params.association == AssociationMethod.JCBB:
                a = assoc.jcbb(
                    x,
                    self._s.P,
                    Rz[unknown],
                    z[unknown],
                    dist,
                    nu,
                    self.gate_match,
                    self.gate_new,
                    self.params.jcbb_confidence,
                )
            else:
                a = assoc.nearest_neighbour(dist, self.gate_match, self.gate_new)
            for k in np.flatnonzero(
                np.isin(unknown, list(decide))
            ).tolist():  # decided elsewhere (the look-ahead); one row a landmark
                s = decide[int(unknown[k])]
                a.decision[(a.slot == s) & (s >= 0)], a.slot[(a.slot == s) & (s >= 0)] = Decision.REJECTED, -1
                a.decision[k], a.slot[k] = (Decision.MATCHED, s) if s >= 0 else (Decision.NEW, -1)
                a.d2[k] = dist[k, s] if s >= 0 else dist[k].min(initial=np.inf)
            decision[unknown], slot[unknown], d2[unknown] = a.decision, a.slot, a.d2
            log_lam, log_new = assoc.log_densities(S, dist, Rz[unknown], self.gate_new)
            matched = a.slot >= 0
            self.log_likelihood += float(
                log_lam[np.flatnonzero(matched), a.slot[matched]].sum() + log_new[~matched].sum()
            )
        return decision, slot, d2

    def _linearisation_points(self, slots) -> tuple[np.ndarray, np.ndarray]:
        """The robot pose (3,) and the positions (k, 2) of landmark slots (k,) the measurement Jacobians are taken at."""
        mode = self.params.jacobians
        if mode == Linearisation.STANDARD:
            return self._s.x[:3], self._landmarks()[slots]
        if mode in (Linearisation.FEJ, Linearisation.OC):
            return self._robot_prior, self._first[slots]
        return self._linearisation_pose(), np.array([self._true_landmark(self._ids[s]) for s in slots]).reshape(-1, 2)

    def _true_landmark(self, landmark_id: int) -> np.ndarray:
        if landmark_id not in self._truth_landmarks:
            raise ValueError(
                f"jacobians='ideal' needs the true position of landmark {landmark_id}: call set_truth(landmarks=...)"
            )
        return self._truth_landmarks[landmark_id]

    def _landmarks(self) -> np.ndarray:
        return self._s.x[3:].reshape(-1, 2)

    def _update_run(self, slots: np.ndarray, z: np.ndarray, R: np.ndarray) -> int:
        """Sequential updates with observations z (k, 2) (noise R (k, 2, 2)) of landmark slots (k,), each H having the five
        non-zero columns idx, in order, until one is not applied (:meth:`_correct` says what is counted or raised then);
        one compiled call (:meth:`.storage.GrowingState.correct_run`). Returns how many were applied."""
        if (
            self.params.jacobians == Linearisation.IDEAL
        ):  # a row without its true landmark raises after the rows before it
            ready = next(
                (k for k, s in enumerate(slots.tolist()) if self._ids[s] not in self._truth_landmarks), slots.size
            )
            if 0 < ready < slots.size:
                applied = self._update_run(slots[:ready], z[:ready], R[:ready])
                return applied if applied < ready else ready + self._update_run(slots[ready:], z[ready:], R[ready:])
        current, XL, ML = self._jacobian_points(slots)
        applied, outcome, k, value, nis, _, S = self._s.correct_run(
            slots.astype(np.int64),
            XL,
            ML,
            current,
            z,
            np.ascontiguousarray(R, dtype=float),
            self.params.covariance_update == CovarianceUpdate.JOSEPH,
        )
        self.nis_log.extend((v, 2) for v in nis.tolist())
        if applied < slots.size:
            self._not_applied(outcome, k, value, S, 1)
        if not self.params.defer_covariance:
            self._s.flush()
        return applied

    def _jacobian_points(self, slots: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray]:
        """Where the compiled updates take H of landmark slots (k,): (True, −, −) at the current estimate (standard), else
        (False, x̆_r per row (k, 3), m̆ (k, 2)) (:meth:`_linearisation_points`)."""
        if self.params.jacobians == Linearisation.STANDARD:
            return True, np.zeros((slots.size, 3)), np.zeros((slots.size, 2))
        xl, ML = self._linearisation_points(slots)
        return False, np.ascontiguousarray(np.broadcast_to(xl, (slots.size, 3))), np.ascontiguousarray(ML, dtype=float)

    def _update_batch(self, slots: np.ndarray, z: np.ndarray, R: np.ndarray) -> bool:
        """One update with m observations of landmark slots (m,): H is 2m × N, five non-zero columns a row pair; HP = H P
        (2m, N), S = H P Hᵀ + blockdiag(R_1 … R_m) and ν in one compiled call (:meth:`.storage.GrowingState.batch_innovation`)."""
        current, XL, ML = self._jacobian_points(slots)
        HP, S, nu = self._s.batch_innovation(
            slots.astype(np.int64),
            XL,
            ML,
            current,
            np.ascontiguousarray(z, dtype=float),
            np.ascontiguousarray(R, dtype=float),
        )
        return self._correct(HP, S, nu)

    def _correct(self, HP: np.ndarray, S: np.ndarray, nu: np.ndarray) -> bool:
        """x ← x + K ν, P ← standard or Joseph form, K = PHᵀ S⁻¹ via the Cholesky factor of the d × d S (d = 2m), O(d N²).

        W = PHᵀ L⁻ᵀ (S = L Lᵀ), K = W L⁻¹ = PHᵀ S⁻¹ (N, d), νᵀ S⁻¹ ν = |L⁻¹ ν|², dx = K ν (:func:`.kernels.gain_terms`), and
        standard: P − K(PHᵀ)ᵀ = P − W Wᵀ, since K (PHᵀ)ᵀ = PHᵀ S⁻¹ (PHᵀ)ᵀ = W Wᵀ;
        Joseph: P − K(PHᵀ)ᵀ − PHᵀKᵀ + K S Kᵀ = P − W Wᵀ + K Dᵀ + D Kᵀ with D = K S − PHᵀ,
        and K Dᵀ + D Kᵀ = ½(K + D)(K + D)ᵀ − ½(K − D)(K − D)ᵀ — all symmetric rank-d terms C diag(s) Cᵀ, deferred (:mod:`.storage`).

        Computed and checked before the state changes (:meth:`.storage.GrowingState.correct`, one compiled call);
        returns whether it was applied. Not applied: a non-finite NIS, state step or covariance term (counted per row in
        ``rejected["nonfinite"]``), an indefinite S or posterior (``on_indefinite``: raise, or count per row and skip).
        """
        outcome, nis, k, value = self._s.correct(HP, S, nu, self.params.covariance_update == CovarianceUpdate.JOSEPH)
        if outcome != APPLIED:
            self._not_applied(outcome, k, value, S, nu.size // 2)
            return False
        if not self.params.defer_covariance:
            self._s.flush()
        self.nis_log.append((float(nis), nu.size))
        return True

    def _not_applied(self, outcome: int, k: int, value: float, S: np.ndarray, rows: int) -> None:
        """An update of ``rows`` observations that :func:`.kernels.correct` did not apply: a non-finite NIS, state step or
        covariance term is counted per row in ``rejected["nonfinite"]``; an indefinite S or posterior goes to ``on_indefinite``."""
        if outcome == NOT_FINITE:
            self.rejected["nonfinite"] += rows
        else:
            self._indefinite(
                innovation_cov_error(S) if outcome == S_INDEFINITE else entries_error(outcome, k, value), rows
            )

    # ------------------------------------------------------------------ new landmarks
    def _add_landmark(self, z: np.ndarray, landmark_id: int | None, R: np.ndarray) -> int:
        """Initialise a landmark from observation z; its slot, or −1 if its mean or covariance is not finite
        (counted in ``rejected["nonfinite"]``) or indefinite (``on_indefinite="record"``) — then nothing changes."""
        new_id = self._next_id if landmark_id is None else landmark_id
        xr = self._s.x[:3].copy()
        m = inverse_observe(xr, z)
        if self.params.jacobians == Linearisation.IDEAL:
            x_true, m_true = self._linearisation_pose(), self._true_landmark(new_id)
            Gx, Gz = inverse_observation_jacobians(x_true, observe(x_true, m_true))
        else:
            Gx, Gz = inverse_observation_jacobians(xr, z)
        robot = self._s.rows([0, 1, 2])  # the current P[0:3, :] (3, N)
        if self.params.init == LandmarkInit.JACOBIAN:
            cross = Gx @ robot  # P_new,: (2, N)
            Pnn = Gx @ robot[:, :3] @ Gx.T + Gz @ R @ Gz.T
            Pnn = 0.5 * (Pnn + Pnn.T)
        else:
            cross, Pnn = np.zeros((2, self._s.n)), self.params.init_cov * np.eye(2)
        if not (np.isfinite(m).all() and np.isfinite(cross).all() and np.isfinite(Pnn).all()):
            self.rejected["nonfinite"] += 1
            return -1
        try:
            check_augmented(self._s.entries(), Pnn)
        except CovarianceError as exc:
            self._indefinite(exc)
            return -1
        N = self._s.n
        new = self._s.grow(2)
        x, P = self._s.x, self._s.stored  # no pending term reaches the new rows (storage.py)
        x[new] = m
        P[new, :N] = cross
        P[:N, new] = cross.T
        P[new, new] = Pnn
        slot = len(self._ids)
        if slot == self._first.shape[0]:
            self._first = np.concatenate([self._first, np.zeros_like(self._first)])
        # FEJ: the first estimate; OC: the anchor that makes the initialisation Jacobian map the robot's nullspace
        # directions onto the landmark's, G_x [I₂, J x̆; 0, 1] = [I₂, J m̆]  ⇔  m̆ = x̆ + (m̂ − x̂)
        self._first[slot] = m + (self._robot_prior[:2] - xr[:2] if self.params.jacobians == Linearisation.OC else 0.0)
        self._ids.append(new_id)
        self._slot[new_id] = slot
        self.book.add(self._t, managed=landmark_id is None)
        self._next_id += landmark_id is None
        return slot

    def _indefinite(self, error: CovarianceError, count: int = 1) -> None:
        """A loss of positive definiteness: raise ``error`` (``on_indefinite="raise"``), or count it."""
        if self.params.on_indefinite == OnIndefinite.RAISE:
            raise error
        self.rejected["indefinite"] += count

    # ``run(sequence) -> Estimate`` is :func:`.run.run_sequence`, bound by the package (this module does not import its
    # runner: the runner imports it)
