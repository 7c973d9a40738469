"""``FastSLAM.run(sequence) -> Estimate``: walk the motion and range-bearing events of a sequence.

The events are walked block by block (:func:`slamarena.estimators.stepping.blocks`): between two observation sets the
motion is one chain (:meth:`FastSLAM.predict_twists` / :meth:`FastSLAM.predict_increments`), cut where ``max_chain``
seconds have passed since the last sampling (the particles are then drawn from the motion model). Every observation set
is one :meth:`FastSLAM.update` at its stamp (the clock of the tentative landmarks). Motion rows with a non-finite value
or one beyond the physical range (``stepping.LIMITS``) are skipped and counted (``rejected_motion``), and so are
observation rows whose range is beyond it (``rejected_out_of_range``), so a corrupt row never aborts the run.

One pose per stamp (every motion and observation event; where several share a stamp, the last — the
posterior — :func:`slamarena.estimators.stepping.last_per_stamp`):

* ``trajectory="mean"``: the weighted mean of the particles (heading: the circular mean) with the
  mixture covariance Σ_m ŵ_m [(x̂_m − x̄)(x̂_m − x̄)ᵀ + P_m] (P_m: the particle's chain covariance,
  zero right after a sampling) — the filter's estimate, whose NEES is defined by that covariance;
* ``trajectory="best"``: the ancestral path of the particle with the largest final weight, found by
  walking the resampling ancestry backwards (the same covariance is given).

The other trajectory is kept in the diagnostics. Landmarks: the heaviest particle's at the end.

Diagnostics (arrays):
    neff, neff_t            N_eff after every update (before resampling) and its stamp
    resampled               whether that update resampled (bool)
    common_ancestor_t       after every update, the time of the particles' most recent common ancestor
                            (:attr:`FastSLAM.common_ancestor_t`): the map is one path's before it
    landmarks_min/mean/max  live landmarks per particle after every update
    best_poses | mean_poses the trajectory not chosen as the estimate's poses
    rejected_nonfinite, rejected_negative_range, rejected_out_of_range, rejected_gate, rejected_motion
                            counts (rejected_gate: labelled rows beyond the known-landmark gate, ``known_confidence``)
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Sequence

from ..models import compose_jacobians
from ..stepping import CLOCKS, Block, blocks, last_per_stamp, observation_rows

__all__ = ["run_sequence", "mixture_moments"]


def mixture_moments(
    x0: np.ndarray, weights: np.ndarray, deltas: np.ndarray, Sigmas: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Mean (K, 3) and covariance (K, 3, 3) of the particle mixture at K stamps of one chain.

    x0 (M, 3) poses at the chain's start, weights (M,) normalised, deltas (K, 3) / Sigmas (K, 3, 3) the
    chain's composed motion and its covariance at each stamp: particle m is N(x0_m ⊕ Δ_k, J_m Σ_k J_mᵀ).
    """
    xhat = compose(x0[None, :, :], deltas[:, None, :])  # (K, M, 3)
    mean = np.einsum("m,kmi->ki", weights, xhat)
    mean[:, 2] = np.arctan2(
        np.einsum("m,km->k", weights, np.sin(xhat[..., 2])), np.einsum("m,km->k", weights, np.cos(xhat[..., 2]))
    )
    d = xhat - mean[:, None, :]
    d[..., 2] = wrap_angle(d[..., 2])
    J = compose_jacobians(x0, np.zeros(3))[1]  # blockdiag(R(θ0_m), 1) (M, 3, 3)
    spread = np.einsum("m,kmi,kmj->kij", weights, d, d)
    chain = np.einsum("m,mia,kab,mjb->kij", weights, J, Sigmas, J)
    return mean, spread + chain


class _History:
    """What the best-path backtracking needs: the poses drawn at every sampling (before resampling) and the
    ancestors of each resampling; and, per event, where its pose comes from."""

    def __init__(self, x0: np.ndarray):
        self.sampled = [x0.copy()]  # sampling 0: the initial particles
        self.ancestors: list[np.ndarray | None] = [None]
        self.events: list[tuple] = []  # ("chain", c, Δ) or ("sample", s)

    def sampling(self, poses: np.ndarray, ancestors: np.ndarray | None, stamped: bool) -> None:
        self.sampled.append(poses.copy())
        self.ancestors.append(None if ancestors is None else ancestors.copy())
        if stamped:
            self.events.append(("sample", len(self.sampled) - 1))

    def chain_event(self, delta: np.ndarray) -> None:
        self.events.append(("chain", len(self.sampled) - 1, delta.copy()))

    def best_path(self, best: int) -> np.ndarray:
        S = len(self.sampled)
        after = np.empty(S, dtype=np.int64)  # particle index after the resampling of each sampling
        before = np.empty(S, dtype=np.int64)  # its index among the poses drawn at that sampling
        i = best
        for s in range(S - 1, -1, -1):
            after[s] = i
            before[s] = i if self.ancestors[s] is None else self.ancestors[s][i]
            i = before[s]
        out = np.empty((len(self.events), 3))
        for k, event in enumerate(self.events):
            if event[0] == "sample":
                out[k] = self.sampled[event[1]][before[event[1]]]
            else:
                c = event[1]
                out[k] = compose(self.sampled[c][before[c]], event[2])
        return out


def run_sequence(slam, sequence: Sequence) -> Estimate:
    """``FastSLAM.run(sequence) -> Estimate`` (bound by the package): the events walked block by block (module docstring)."""
    slam.reset(sequence)
    z_all = sequence.range_bearing.z if sequence.range_bearing is not None else np.zeros((0, 3))
    record = _Record(slam, CLOCKS[slam.params.step_clock], sequence.t0)
    rejected = {"motion": 0, "out_of_range": 0}
    for block in blocks(sequence, row_cov=slam.params.increment_cov is None):
        rejected["motion"] += block.motion.rejected
        _predict(slam, block, record)
        if block.observation is not None:
            rows, far = observation_rows(block.observation, z_all[:, 0])
            rejected["out_of_range"] += far
            slam.update(z_all[rows], block.observation.t)
            record.update(slam, block.observation.t)
    return _estimate(slam, sequence, record, rejected)


def _predict(slam, block: Block, record: _Record) -> None:
    """Propagate the particles over the block's motion chain, cut every ``max_chain`` seconds since the last sampling
    (the particles are then drawn from the motion model); record the mixture at each motion event's stamp."""
    motion, chain, p = block.motion, block.chain, slam.params
    ends = motion.end
    event_piece = motion.at_event - 1  # the last piece applied by each event's stamp (−1: none)
    start, e0 = 0, 0
    while True:
        cut = int(np.searchsorted(ends, record.t_sampled + p.max_chain, side="left"))
        stop = min(max(cut, start) + 1, ends.size)
        before = (slam.delta.copy(), slam.Sigma_delta.copy())
        deltas, Sigmas = motion.predict(slam, start, stop) if stop > start else (np.zeros((0, 3)), np.zeros((0, 3, 3)))
        e1 = e0
        while e1 < len(chain) and event_piece[e1] < stop:
            e1 += 1
        if e1 > e0:  # the motion events in this part of the chain: the chain's composed motion at each stamp
            k = event_piece[e0:e1] - start
            if deltas.size:
                D = np.where(k[:, None] >= 0, deltas[np.maximum(k, 0)], before[0])
                S = np.where(k[:, None, None] >= 0, Sigmas[np.maximum(k, 0)], before[1])
            else:
                D, S = np.tile(before[0], (e1 - e0, 1)), np.tile(before[1], (e1 - e0, 1, 1))
            record.chain(slam, chain[e0:e1], D, S)
        e0 = e1
        if stop >= ends.size or cut >= ends.size:
            break
        slam.sample_motion()  # max_chain seconds without an observation
        record.history.sampling(slam.x0, None, stamped=False)
        record.t_sampled = ends[stop - 1]
        start = stop


class _Record:
    """The recorded trajectory (the particle mixture's mean and covariance and the step time per event), the history
    for the best path, and the per-update diagnostics."""

    def __init__(self, slam, timer, t0: float):
        self.history = _History(slam.x0)
        self.t_sampled = t0  # the time of the last sampling of the particles
        self.timer, self.clock = timer, timer()
        self.times, self.means, self.covs, self.steps = [], [], [], []
        self.neff, self.neff_t, self.resampled, self.counts, self.ancestor_t = [], [], [], [], []

    def chain(self, slam, events: list, D: np.ndarray, S: np.ndarray) -> None:
        """The mixture at the stamps of motion ``events``: the chain's composed motion D (E, 3), S (E, 3, 3) at each;
        the time since the last record is shared evenly by them."""
        mean, cov = mixture_moments(slam.x0, slam.weights, D, S)
        now = self.timer()
        for q, event in enumerate(events):
            self.times.append(event.t)
            self.history.chain_event(D[q])
            self.steps.append((now - self.clock) / len(events))
        self.means += list(mean)
        self.covs += list(cov)
        self.clock = now

    def update(self, slam, t: float) -> None:
        """The mixture after the update at t (the particles as sampled, weighted by the update) and its diagnostics."""
        weights = np.exp(slam.last_log_w - slam.last_log_w.max())
        weights /= weights.sum()
        mean, cov = mixture_moments(slam.last_sampled, weights, np.zeros((1, 3)), np.zeros((1, 3, 3)))
        self.history.sampling(slam.last_sampled, slam.last_ancestors, stamped=True)
        self.t_sampled = t
        self.times.append(t)
        self.means.append(mean[0])
        self.covs.append(cov[0])
        self.neff.append(1.0 / np.sum(weights**2))
        self.neff_t.append(t)
        self.resampled.append(slam.last_ancestors is not None)
        self.ancestor_t.append(slam.common_ancestor_t)
        live = slam.landmark_counts()
        self.counts.append((live.min(), live.mean(), live.max()))
        now = self.timer()
        self.steps.append(now - self.clock)
        self.clock = now


def _estimate(slam, sequence: Sequence, record: _Record, rejected: dict) -> Estimate:
    """The :class:`Estimate`: one pose per stamp (the mean or the best path), the heaviest particle's landmarks, the
    diagnostics and meta."""
    p = slam.params
    t, steps, mean_poses, covs, best = last_per_stamp(
        np.asarray(record.times),
        np.asarray(record.steps),
        np.asarray(record.means).reshape(-1, 3),
        np.asarray(record.covs).reshape(-1, 3, 3),
        record.history.best_path(int(np.argmax(slam.log_w))),
    )
    ids, xy, lcov = slam.landmarks()
    counts = np.asarray(record.counts, dtype=float).reshape(-1, 3)
    diagnostics = {
        "neff": np.asarray(record.neff),
        "neff_t": np.asarray(record.neff_t),
        "resampled": np.asarray(record.resampled, dtype=bool),
        "common_ancestor_t": np.asarray(record.ancestor_t, dtype=float),
        "landmarks_min": counts[:, 0],
        "landmarks_mean": counts[:, 1],
        "landmarks_max": counts[:, 2],
        "rejected_nonfinite": np.array(slam.rejected["nonfinite"]),
        "rejected_negative_range": np.array(slam.rejected["negative_range"]),
        "rejected_out_of_range": np.array(rejected["out_of_range"]),
        "rejected_gate": np.array(slam.rejected["gate"]),
        "rejected_motion": np.array(rejected["motion"]),
    }
    if p.trajectory == "mean":
        poses, diagnostics["best_poses"] = mean_poses, best
    else:
        poses, diagnostics["mean_poses"] = best, mean_poses
    meta = {
        "params": p.canonical(),
        "sequence": sequence.name,
        "resamplings": slam.resamplings,
        "n_landmarks": int(len(ids)),
        "noise": {"twist_cov": slam.M_twist.tolist(), "range_bearing_cov": slam.R.tolist()},
        "map_bytes": slam.store.nbytes(),
    }
    return Estimate(
        method=f"fastslam{p.version}",
        t=t,
        poses=poses,
        pose_cov=covs,
        landmark_ids=ids,
        landmarks=xy,
        landmark_cov=lcov,
        step_time=steps,
        diagnostics=diagnostics,
        meta=meta,
    )
