"""The grid-based Rao-Blackwellised particle filter (GMapping-style; the package docstring has the model).

Per scan k (every scan of ``sequence.scans``; P particles, each with a pose ξ_i, a log-weight and a map):

1. Beams as in :mod:`slamarena.mapping.grid_slam` (bad readings rejected and counted; no-returns clear up to
   ``clear_range``; usable returns are matched and mapped).
2. Odometry (:mod:`slamarena.mapping.odometry`): at a fresh reading o_k every particle's guess is
   ``ĝ_i = ξ_i(f) ⊕ (⊖o_f ⊕ o_k)``, f the scan of the last fresh reading; otherwise ``ĝ_i = ξ_i``.
3. A **filter step** when the odometry moved ``update_distance`` or turned ``update_angle`` since the last
   filter step (and at the first ``initial_updates`` usable scans): the improved proposal
   (:mod:`slamarena.mapping.rbpf.proposal`) with Σ_u of the odometry motion since the last filter step,
   a new pose per particle (``proposal``: a draw from the fitted Gaussian, or the scan-matched optimum of a
   motion-model draw), log-weights += log η_i, ``N_eff = 1 / Σ w̃_i²``, every particle's map integrates the
   scan at its drawn pose, and when ``N_eff < resample_threshold · P`` systematic resampling (tables copied,
   tiles shared: :mod:`slamarena.mapping.rbpf.tiled_grid`), weights reset.
   Between filter steps each particle **tracks**: its pose becomes the mode of the same target with Σ_u of
   the scan's own odometry increment (no draw, no weight, no map update), so every scan stamp has a pose
   consistent with the particle's map.
4. Scans with fewer than ``min_beams`` usable beams keep the guesses (not matched, counted).

Output: an :class:`~slamarena.datasets.estimate.Estimate` with the trajectory of the best particle after the
last scan, traced back through the resampling ancestry, at every scan stamp (any final particle's lineage:
:meth:`RBPF.trajectory`). The best particle is the one
whose lineage has the largest ``Σ log η`` over all filter steps (GMapping's choice): right after resampling
every weight is equal, while the lineage's evidence still tells the particles apart.
``diagnostics`` (per scan): ``bad_beams``, ``no_return_beams``, ``usable_beams``, ``matched``, ``iterations``
(Gauss-Newton iterations summed over levels and particles),
``filter_step``, ``proposal_fallbacks`` (particles drawn from the motion model), ``memory_per_particle`` [bytes, NaN
off filter steps]; per weighted filter step (every filter step after the first): ``neff`` (N_eff before
resampling), ``neff_t`` (its scan stamp), ``resampled`` (whether that step resampled). ``meta``: the counts of
GridSLAM's, ``particles``, ``filter_steps``, ``resampling_events``, ``memory_per_particle`` (final and peak),
``memory_unshared_per_particle`` (what unshared maps of the same tiles would take). After ``run``
``self.map`` is the best particle's finest grid (an :class:`~slamarena.mapping.occupancy_grid.OccupancyGrid`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import NonNegativeFloat, NonNegativeInt, PositiveFloat, PositiveInt

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, compose, transform_points, wrap_angle
from slamarena.datasets.sequence import Scans, Sequence
from slamarena.params import Field, Params

from ..beams import classify, scan_counts
from ..map_pyramid import PyramidParams, initial_side
from ..occupancy_grid import CellModelParams, OccupancyGrid
from ..odometry import fresh_readings
from .proposal import degeneracy, degenerate_direction, gauss_newton, quadrature, residuals
from .tiled_grid import TiledPyramid

__all__ = ["RBPF", "RBPFParams", "MotionNoiseParams", "systematic_resampling"]


class MotionNoiseParams(Params):
    """The odometry motion model's noise: Σ_u = diag(σ_t², σ_t², σ_r²) with
    ``σ_t = sigma_t_min + sigma_t_per_m·d + sigma_t_per_rad·|Δθ|`` and
    ``σ_r = sigma_r_min + sigma_r_per_rad·|Δθ| + sigma_r_per_m·d`` for an odometry motion of d metres and
    Δθ radians (isotropic in translation, hence the same in every frame)."""

    sigma_t_min: PositiveFloat = Field(0.1, description="σ_t of the motion model at rest [m]")
    sigma_t_per_m: NonNegativeFloat = Field(0.1, description="σ_t per metre travelled [m/m]")
    sigma_t_per_rad: NonNegativeFloat = Field(0.05, description="σ_t per radian turned [m/rad]")
    sigma_r_min: PositiveFloat = Field(0.1, description="σ_r of the motion model at rest [rad]")
    sigma_r_per_rad: NonNegativeFloat = Field(0.1, description="σ_r per radian turned [rad/rad]")
    sigma_r_per_m: NonNegativeFloat = Field(0.05, description="σ_r per metre travelled [rad/m]")

    def cov(self, motion: np.ndarray) -> np.ndarray:
        """Σ_u (3, 3) of an odometry motion ``(dx, dy, dθ)``."""
        d, a = float(np.hypot(motion[0], motion[1])), abs(float(wrap_angle(motion[2])))
        st = self.sigma_t_min + self.sigma_t_per_m * d + self.sigma_t_per_rad * a
        sr = self.sigma_r_min + self.sigma_r_per_rad * a + self.sigma_r_per_m * d
        return np.diag([st**2, st**2, sr**2])


class RBPFParams(Params):
    """Parameters of :class:`RBPF` (module docstring): particles and resampling, the scan likelihood, the
    odometry motion model (``motion``, :class:`MotionNoiseParams`), when filter steps happen, the matcher's
    iterations, the maps (``pyramid``: levels and cell model, :class:`~slamarena.mapping.map_pyramid.PyramidParams`;
    tile size) and the beams used."""

    particles: PositiveInt = Field(30, description="number of particles P")
    proposal: Literal["gaussian", "mode"] = Field(
        "mode",
        description="gaussian: draw from the Gaussian fitted to the target "
        "(Grisetti 2007); mode: draw from the motion model and keep the scan-matched optimum "
        "of that draw (GMapping's code; module docstring of .proposal)",
    )
    seed: NonNegativeInt = Field(0, description="seed of the draws and of resampling (numpy.random.default_rng)")
    resample_threshold: float = Field(0.5, gt=0.0, le=1.0, description="resample when N_eff < resample_threshold · P")
    sigma_likelihood: PositiveFloat = Field(
        1.0, description="σ_z of the residuals 1 − M of the scan likelihood (larger: flatter weights)"
    )
    weight_tempering: float = Field(
        1.0,
        gt=0.0,
        le=1.0,
        description="γ: each filter step multiplies the weights by η^γ (γ < 1: flatter weights, fewer resamplings)",
    )
    motion: MotionNoiseParams = Field(MotionNoiseParams(), description="the odometry motion model's noise")
    update_distance: NonNegativeFloat = Field(
        0.5, description="a filter step after the odometry moved this far since the last one [m]"
    )
    update_angle: NonNegativeFloat = Field(
        0.25, description="a filter step after the odometry turned this much since the last one [rad]"
    )
    initial_updates: NonNegativeInt = Field(
        10, description="every usable scan is a filter step until the maps hold this many scans"
    )
    iterations: PositiveInt = Field(10, description="most Gauss-Newton iterations per pyramid level")
    tol_translation: NonNegativeFloat = Field(
        5e-4, description="a level stops when a step moves less than this [m] (and turns less than tol_rotation)"
    )
    tol_rotation: NonNegativeFloat = Field(
        5e-4, description="a level stops when a step turns less than this [rad] (and moves less than tol_translation)"
    )
    max_step_translation: PositiveFloat = Field(
        0.1, description="step clamp on the finest level [m], scaled with each level's resolution"
    )
    max_step_rotation: PositiveFloat = Field(0.2, description="step clamp [rad]")
    step_halvings: NonNegativeInt = Field(
        4,
        description="a Gauss-Newton step that does not lower −log τ is halved up to this many times, and a level stops "
        "where none does (a descent: research/notebook/2026-11-23-rbpf-loop-rounds-4-6.md, rounds 4–6); "
        "0: every step is taken",
    )
    degeneracy_threshold: NonNegativeFloat = Field(
        0.0,
        description="τ: a translation direction where the scan's geometric information is below τ times that of the "
        "other is degenerate, and the particles keep their odometry guess along it (.proposal docstring; 0, the default: off; "
        "0.003 separates the simulated corridor from the simulated rooms)",
    )
    pyramid: PyramidParams = Field(
        PyramidParams(cells=CellModelParams(hit_guard=1)),
        description="every particle's map pyramid and its cell model (hit_guard 1: cells around a hit are not cleared)",
    )
    tile: PositiveInt = Field(64, description="side of the copy-on-write map tiles [cells]")
    clear_range: PositiveFloat = Field(5.0, description="how far a no-return reading clears space [m]")
    max_usable_range: PositiveFloat | None = Field(
        15.0, description="longer returns are neither matched nor mapped [m]; None: all returns"
    )
    min_beams: int = Field(10, ge=3, description="fewest usable beams (and end points on observed cells) for a match")


def systematic_resampling(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Ancestor indices (P,) by systematic (low-variance) resampling of normalised ``weights`` (P,)."""
    P = weights.size
    u = (rng.uniform() + np.arange(P)) / P
    c = np.cumsum(weights)
    c[-1] = 1.0
    return np.searchsorted(c, u, side="right").astype(np.int64)


def _checked_scans(sequence: Sequence):
    """The sequence's scans, which must exist and carry the odometry poses (``Scans.pose``)."""
    scans = sequence.scans
    if scans is None or len(scans) == 0:
        raise ValueError(f"RBPF needs a sequence with laser scans; {sequence.name!r} has none")
    if scans.pose is None:
        raise ValueError(
            f"RBPF needs the odometry poses attached to the scans (Scans.pose); {sequence.name!r} has none"
        )
    return scans


@dataclass
class _Run:
    """The state of one :meth:`RBPF.run`: the scans and their odometry, the particles (poses (P, 3), log-weights and
    lineage evidence (P,), the odometry anchor of the guesses and of the last filter step), the filter steps so far,
    the per-scan histories (poses (K, P, 3), ancestors (K, P)) and diagnostics."""

    scans: Scans
    P: int
    rng: np.random.Generator
    odom: np.ndarray
    fresh: np.ndarray
    limit: float
    poses: np.ndarray
    anchor: np.ndarray
    odom_anchor: np.ndarray | None
    odom_filter: np.ndarray | None
    logw: np.ndarray
    evidence: np.ndarray  # Σ log η along each particle's lineage, never reset (the best particle's criterion)
    hist_pose: np.ndarray
    hist_parent: np.ndarray
    parent: np.ndarray  # this scan's ancestors (the identity unless it resampled)
    step_time: np.ndarray
    n_beams: np.ndarray
    diag: dict
    neff: list = field(default_factory=list)
    neff_t: list = field(default_factory=list)
    resampled: list = field(default_factory=list)
    updates: int = 0


class RBPF:
    """Grid-based Rao-Blackwellised particle filter with the improved proposal (module docstring, :class:`RBPFParams`)."""

    Params = RBPFParams

    def __init__(self, params: RBPFParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.maps: TiledPyramid | None = None
        self.best: int | None = None
        self._map: OccupancyGrid | None = None
        self._history: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def map(self) -> OccupancyGrid | None:
        """The finest grid of the best particle after :meth:`run` (a dense copy, made on first use)."""
        if self._map is None and self.maps is not None:
            self._map = self.maps.finest.dense(self.best)
        return self._map

    def trajectory(self, i: int) -> np.ndarray:
        """Poses (K, 3) at every scan of the lineage of final particle ``i`` after :meth:`run` (traced back
        through the resampling ancestry; :meth:`run`'s estimate is that of the best particle)."""
        if self._history is None:
            raise ValueError("RBPF.trajectory needs a run() first")
        hist_pose, hist_parent = self._history
        trajectory = np.zeros((hist_pose.shape[0], 3))
        for k in range(hist_pose.shape[0] - 1, -1, -1):
            trajectory[k] = hist_pose[k, i]
            i = hist_parent[k, i]
        return trajectory

    def run(self, sequence: Sequence, progress=None) -> Estimate:
        """Filter ``sequence.scans``; ``progress(k, K)`` is called after each scan when given."""
        scans = _checked_scans(sequence)
        run = self._start(sequence)
        for k in range(len(scans)):
            t0 = time.perf_counter()
            run.parent = np.arange(run.P)
            r, a, bad, no_return, usable = self._beams(run, k)
            motion = self._predict(run, k)
            if usable.sum() >= self.params.min_beams:
                pts = transform_points(
                    scans.mount, np.column_stack([r[usable] * np.cos(a[usable]), r[usable] * np.sin(a[usable])])
                )
                since, step = self._filter_step_due(run, k)
                if run.updates > 0 and not step:
                    self._track(run, k, pts, motion)
                elif step:
                    self._filter_step(run, k, pts, since, r, a, bad, no_return)
            self._record(run, k)
            run.step_time[k] = time.perf_counter() - t0
            if progress is not None:
                progress(k + 1, len(scans))
        return self._estimate(run)

    def _gauss_newton_options(self) -> dict:
        """The Gauss-Newton matcher's keyword options (:func:`.proposal.gauss_newton`) from the parameters."""
        p = self.params
        return dict(
            sigma=p.sigma_likelihood,
            iterations=p.iterations,
            tol_t=p.tol_translation,
            tol_r=p.tol_rotation,
            max_step_t=p.max_step_translation,
            max_step_r=p.max_step_rotation,
            halvings=p.step_halvings,
        )

    def _basis(self, pts: np.ndarray):
        """The degenerate direction of the scan ``pts`` (N, 2) (:func:`.proposal.degeneracy`), None when there is none
        or ``degeneracy_threshold`` is 0."""
        p = self.params
        if p.degeneracy_threshold == 0:
            return None
        return degeneracy(pts, p.degeneracy_threshold)

    def _start(self, sequence: Sequence) -> _Run:
        """The run's state before the first scan: P particles at the start pose (the first fresh odometry pose, else
        the sequence's), one empty shared map pyramid (``self.maps``), zero weights, empty histories."""
        p, scans = self.params, sequence.scans
        K, P = len(scans), p.particles
        odom = scans.pose
        fresh = fresh_readings(odom)
        start = odom[0] if fresh[0] else np.asarray(sequence.start_pose, dtype=float)
        self.maps = TiledPyramid(
            P, p.pyramid, p.tile, size=initial_side(min(scans.max_range, p.clear_range)), centre=tuple(start[:2])
        )
        poses = np.tile(np.asarray(start, dtype=float), (P, 1))
        return _Run(
            scans=scans,
            P=P,
            rng=np.random.default_rng(p.seed),
            odom=odom,
            fresh=fresh,
            limit=scans.max_range if p.max_usable_range is None else min(scans.max_range, p.max_usable_range),
            poses=poses,
            anchor=poses.copy(),
            odom_anchor=odom[0] if fresh[0] else None,
            odom_filter=odom[0] if fresh[0] else None,
            logw=np.zeros(P),
            evidence=np.zeros(P),
            hist_pose=np.zeros((K, P, 3)),
            hist_parent=np.zeros((K, P), np.int64),
            parent=np.arange(P),
            step_time=np.zeros(K),
            n_beams=np.zeros(K, np.int64),
            diag={
                "bad_beams": np.zeros(K, np.int64),
                "no_return_beams": np.zeros(K, np.int64),
                "usable_beams": np.zeros(K, np.int64),
                "matched": np.zeros(K, bool),
                "iterations": np.zeros(K, np.int64),
                "filter_step": np.zeros(K, bool),
                "proposal_fallbacks": np.zeros(K, np.int64),
                "memory_per_particle": np.full(K, np.nan),
            },
        )

    def _beams(self, run: _Run, k: int):
        """Scan k's ranges r (B_k,), angles a (B_k,) and its masks bad, no_return, usable (B_k,), counted in diag."""
        r, a = run.scans.beams(k)
        run.n_beams[k] = r.size
        bad, no_return, usable = classify(r, run.scans.max_range, run.limit)
        run.diag["bad_beams"][k], run.diag["no_return_beams"][k], run.diag["usable_beams"][k] = (
            bad.sum(),
            no_return.sum(),
            usable.sum(),
        )
        return r, a, bad, no_return, usable

    def _predict(self, run: _Run, k: int) -> np.ndarray:
        """At a fresh odometry reading, every particle's guess ĝ_i = anchor_i ⊕ (⊖o_f ⊕ o_k) (``run.poses`` (P, 3));
        returns that odometry motion (3,), zero without a fresh reading."""
        motion = np.zeros(3)
        if run.fresh[k] and run.odom_anchor is not None:
            motion = between(run.odom_anchor, run.odom[k])
            run.poses = compose(run.anchor, motion)
        return motion

    def _filter_step_due(self, run: _Run, k: int) -> tuple[np.ndarray, bool]:
        """The odometry motion (3,) since the last filter step and whether scan k is a filter step (the first
        ``initial_updates``, or moved ``update_distance`` / turned ``update_angle``)."""
        p = self.params
        since = between(run.odom_filter, run.odom[k]) if (run.fresh[k] and run.odom_filter is not None) else np.zeros(3)
        step = (
            run.updates < max(p.initial_updates, 1)
            or np.hypot(since[0], since[1]) >= p.update_distance
            or abs(wrap_angle(since[2])) >= p.update_angle
        )
        return since, step

    def _track(self, run: _Run, k: int, pts: np.ndarray, motion: np.ndarray) -> None:
        """Between filter steps: every particle's pose (P, 3) becomes the mode of its target from the guess, with Σ_u
        of the scan's odometry ``motion`` (3,); no draw, no weight, no map update."""
        run.poses, run.diag["iterations"][k] = gauss_newton(
            self.maps,
            pts,
            run.poses,
            np.linalg.inv(self.params.motion.cov(motion)),
            basis=self._basis(pts),
            **self._gauss_newton_options(),
        )
        run.diag["matched"][k] = True

    def _filter_step(self, run: _Run, k: int, pts, since, r, a, bad, no_return) -> None:
        """A filter step at scan k: weigh the proposal (after the first), integrate the scan (B_k,) into every map at
        its particle's pose, resample when N_eff is low; the odometry of this step is remembered."""
        w = self._weigh(run, k, pts, since) if run.updates > 0 else None
        self._integrate(run, r, a, bad, no_return)
        if run.updates > 0 and run.resampled[-1]:
            self._resample(run, w)
        run.odom_filter = run.odom[k] if run.fresh[k] else run.odom_filter
        run.updates += 1
        run.diag["filter_step"][k] = True
        run.diag["memory_per_particle"][k] = self.maps.memory()["per_particle"]

    def _weigh(self, run: _Run, k: int, pts: np.ndarray, since: np.ndarray) -> np.ndarray:
        """Draw the new poses (P, 3) from the improved proposal with Σ_u of ``since``, add γ log η to the log-weights
        and log η to the evidence; N_eff and whether to resample are recorded. Returns the normalised weights (P,)."""
        p = self.params
        run.poses, fallbacks, log_eta, run.diag["iterations"][k] = self._propose(
            pts, run.poses, p.motion.cov(since), run.rng
        )
        run.logw += p.weight_tempering * log_eta
        run.evidence += log_eta
        run.logw -= run.logw.max()
        w = np.exp(run.logw)
        w /= w.sum()
        run.neff.append(1.0 / np.sum(w**2))
        run.neff_t.append(run.scans.t[k])
        run.resampled.append(bool(run.neff[-1] < p.resample_threshold * run.P))
        run.diag["proposal_fallbacks"][k] = fallbacks
        run.diag["matched"][k] = fallbacks < run.P
        return w

    def _integrate(self, run: _Run, r, a, bad, no_return) -> None:
        """Every particle's map integrates the scan's mapped beams at its pose (the first scan once, shared by all)."""
        p = self.params
        mapped = ~bad & ((r < run.limit) | no_return)
        hit = r[mapped] < run.limit
        reach = np.where(hit, r[mapped], np.minimum(r[mapped], p.clear_range))
        sensors = compose(run.poses, run.scans.mount)
        if run.updates == 0:  # every particle starts from the same map: integrate once, share it
            self.maps.integrate(sensors, reach, a[mapped], hit, which=[0])
            self.maps.resample(np.zeros(run.P, np.int64))
        else:
            self.maps.integrate(sensors, reach, a[mapped], hit)

    def _resample(self, run: _Run, w: np.ndarray) -> None:
        """Systematic resampling by the weights w (P,): maps, poses and evidence follow the ancestors, weights reset."""
        run.parent = systematic_resampling(w, run.rng)
        self.maps.resample(run.parent)
        run.poses, run.logw, run.evidence = run.poses[run.parent], np.zeros(run.P), run.evidence[run.parent]

    def _record(self, run: _Run, k: int) -> None:
        """After scan k: at a fresh reading the poses become the odometry anchor; poses and ancestors (P,) stored."""
        if run.fresh[k]:
            run.anchor, run.odom_anchor = run.poses.copy(), run.odom[k]
            run.odom_filter = run.odom[k] if run.odom_filter is None else run.odom_filter
        run.hist_pose[k], run.hist_parent[k] = run.poses, run.parent

    def _estimate(self, run: _Run) -> Estimate:
        """The best particle's lineage (K, 3) as the estimate, with the diagnostics and meta (module docstring)."""
        p, diag, P = self.params, run.diag, run.P
        diag.update(
            neff=np.asarray(run.neff, dtype=float),
            neff_t=np.asarray(run.neff_t, dtype=float),
            resampled=np.asarray(run.resampled, dtype=bool),
        )
        self.best, self._map = int(np.argmax(run.evidence)), None
        self._history = (run.hist_pose, run.hist_parent)
        trajectory = self.trajectory(self.best)
        memory = self.maps.memory()
        finest = self.maps.finest
        K, B = run.scans.ranges.shape
        meta = {
            "params": p.canonical(),
            "scans": int(K),
            "beams": int(B),
            "particles": int(P),
            **scan_counts(diag, run.n_beams),
            "filter_steps": int(diag["filter_step"].sum()),
            "map_updates": int(diag["filter_step"].sum()),
            "resampling_events": int(diag["resampled"].sum()),
            "proposal_fallbacks": int(diag["proposal_fallbacks"].sum()),
            "best_particle": self.best,
            "memory_per_particle": float(memory["per_particle"]),
            "memory_per_particle_peak": float(np.nanmax(diag["memory_per_particle"]))
            if diag["filter_step"].any()
            else 0.0,
            "memory_unshared_per_particle": float(memory["unshared"] / P),
            "map_shape": list(finest.shape),
            "map_origin": finest.origin.tolist(),
        }
        return Estimate(
            method="rbpf", t=run.scans.t.copy(), poses=trajectory, step_time=run.step_time, diagnostics=diag, meta=meta
        )

    def _propose(self, pts, guesses, motion_cov, rng):
        """New poses (P, 3), the number drawn from the motion model, log η (P,) (:mod:`.proposal`) and the matcher's
        iterations. ``proposal="gaussian"``: the mode of τ_i from ĝ_i, the 27 points, a draw from N(μ_i, Σ_i).
        ``proposal="mode"``: a draw x_i ~ N(ĝ_i, Σ_u), the mode ξ*_i of τ_i from x_i and log η_i around it (the
        27 points), then the pose is the optimum of p(z | m_i, ξ) N(ξ; x_i, Σ_u) (the finest level, from ξ*_i)."""
        p = self.params
        P = guesses.shape[0]
        info = np.linalg.inv(motion_cov)
        gn = dict(self._gauss_newton_options(), basis=self._basis(pts))
        eps = rng.standard_normal((P, 3))
        step = eps @ np.linalg.cholesky(motion_cov).T
        if gn["basis"] is not None:  # no draw along the degenerate direction (.proposal docstring, "Degeneracy")
            t0 = degenerate_direction(gn["basis"], guesses)
            step -= t0 * np.einsum("pi,pi->p", t0, step)[:, None]
        from_motion = guesses + step
        modes, iterations = gauss_newton(
            self.maps, pts, guesses, info, start=from_motion if p.proposal == "mode" else None, **gn
        )
        mu, cov, log_eta, known = quadrature(
            self.maps, pts, modes, guesses, motion_cov, p.sigma_likelihood, basis=gn["basis"]
        )
        ok = (known >= p.min_beams) & np.isfinite(log_eta) & np.all(np.isfinite(mu), axis=1)
        poses = from_motion.copy()
        if p.proposal == "gaussian":
            poses[ok] = mu[ok] + np.einsum("pij,pj->pi", np.linalg.cholesky(cov[ok] + 1e-12 * np.eye(3)), eps[ok])
        elif ok.any():
            poses[ok], climbed = gauss_newton(
                self.maps, pts, from_motion[ok], info, start=modes[ok], finest_only=True, **gn
            )
            iterations += climbed
        bad = ~ok
        if bad.any():
            ssr, _, _ = residuals(self.maps, pts, from_motion[bad][:, None, :])
            log_eta = log_eta.copy()
            log_eta[bad] = -0.5 * ssr[:, 0] / p.sigma_likelihood**2
        poses[:, 2] = wrap_angle(poses[:, 2])
        return poses, int(bad.sum()), log_eta, iterations
