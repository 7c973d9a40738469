"""``FastSLAM.run(sequence) -> Estimate``: walk the motion and range-bearing events of a sequence.

Between two observation sets the motion is one chain (:meth:`FastSLAM.predict_twists` /
:meth:`FastSLAM.predict_increments`), cut where ``max_chain`` seconds have passed since the last
sampling (the particles are then drawn from the motion model). Every observation set is one
:meth:`FastSLAM.update` at its stamp (the clock of the tentative landmarks).

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
    rejected_nonfinite, rejected_negative_range, rejected_gate, rejected_motion   counts (rejected_gate: labelled rows
                            beyond the known-landmark gate, ``known_confidence``)
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Increments, Sequence, Twist

from ..models import compose_jacobians
from ..stepping import CLOCKS, last_per_stamp, twist_pieces

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
    slam.reset(sequence)
    p = slam.params
    motion, rb = sequence.motion, sequence.range_bearing
    table = [e for e in sequence.events() if e.stream in ("motion", "range_bearing")]
    history = _History(slam.x0)
    times, means, covs, steps = [], [], [], []
    neff, neff_t, resampled, counts, ancestor_t = [], [], [], [], []
    rejected_motion = 0
    t_now = t_sampled = sequence.t0
    timer = CLOCKS[p.step_clock]
    clock = timer()
    i = 0
    while i < len(table):
        j = i
        while j < len(table) and table[j].stream == "motion":
            j += 1
        chain = table[i:j]
        t_end = table[j].t if j < len(table) else (chain[-1].t if chain else t_now)
        if isinstance(motion, Twist):
            v, w, dts = twist_pieces(motion, t_now, t_end)
            ok = np.isfinite(v) & np.isfinite(w)
            rejected_motion += int((~ok).sum())
            ends = (t_now + np.cumsum(dts))[ok]
            v, w, dts = v[ok], w[ok], dts[ok]
            advance = lambda a, b: slam.predict_twists(v[a:b], w[a:b], dts[a:b])  # noqa: E731
        elif isinstance(motion, Increments):
            rows = np.arange(chain[0].start, chain[-1].stop) if chain else np.zeros(0, dtype=int)
            ok = np.all(np.isfinite(motion.delta[rows]), axis=1)
            rejected_motion += int((~ok).sum())
            rows = rows[ok]
            ends = motion.t[rows]
            C = motion.cov[rows] if (motion.cov is not None and p.increment_cov is None) else None
            advance = lambda a, b: slam.predict_increments(motion.delta[rows[a:b]], None if C is None else C[a:b])  # noqa: E731
        else:
            ends = np.zeros(0)
            advance = None
        # the chain, cut every max_chain seconds since the last sampling
        event_piece = np.array([np.searchsorted(ends, e.t + 1e-9, side="right") - 1 for e in chain], dtype=np.int64)
        start, e0 = 0, 0
        while True:
            cut = int(np.searchsorted(ends, t_sampled + p.max_chain, side="left"))
            stop = min(max(cut, start) + 1, ends.size)
            before = (slam.delta.copy(), slam.Sigma_delta.copy())
            deltas, Sigmas = advance(start, stop) if stop > start else (np.zeros((0, 3)), np.zeros((0, 3, 3)))
            e1 = e0
            while e1 < len(chain) and event_piece[e1] < stop:
                e1 += 1
            if e1 > e0:  # the motion events in this part of the chain
                k = event_piece[e0:e1] - start
                D = (
                    np.where(k[:, None] >= 0, deltas[np.maximum(k, 0)], before[0])
                    if deltas.size
                    else np.tile(before[0], (e1 - e0, 1))
                )
                S = (
                    np.where(k[:, None, None] >= 0, Sigmas[np.maximum(k, 0)], before[1])
                    if deltas.size
                    else np.tile(before[1], (e1 - e0, 1, 1))
                )
                mean, cov = mixture_moments(slam.x0, slam.weights, D, S)
                now = timer()
                for q in range(e1 - e0):
                    times.append(chain[e0 + q].t)
                    history.chain_event(D[q])
                    steps.append((now - clock) / (e1 - e0))
                means += list(mean)
                covs += list(cov)
                clock = now
            e0 = e1
            if stop >= ends.size or cut >= ends.size:
                break
            slam.sample_motion()  # max_chain seconds without an observation
            history.sampling(slam.x0, None, stamped=False)
            t_sampled = ends[stop - 1]
            start = stop
        t_now = t_end
        if j < len(table):
            event = table[j]
            slam.update(rb.z[event.start : event.stop], event.t)
            weights = np.exp(slam.last_log_w - slam.last_log_w.max())
            weights /= weights.sum()
            mean, cov = mixture_moments(slam.last_sampled, weights, np.zeros((1, 3)), np.zeros((1, 3, 3)))
            history.sampling(slam.last_sampled, slam.last_ancestors, stamped=True)
            t_sampled = event.t
            times.append(event.t)
            means.append(mean[0])
            covs.append(cov[0])
            neff.append(1.0 / np.sum(weights**2))
            neff_t.append(event.t)
            resampled.append(slam.last_ancestors is not None)
            ancestor_t.append(slam.common_ancestor_t)
            live = slam.landmark_counts()
            counts.append((live.min(), live.mean(), live.max()))
            now = timer()
            steps.append(now - clock)
            clock = now
        i = j + 1

    t, steps, mean_poses, covs, best = last_per_stamp(
        np.asarray(times),
        np.asarray(steps),
        np.asarray(means).reshape(-1, 3),
        np.asarray(covs).reshape(-1, 3, 3),
        history.best_path(int(np.argmax(slam.log_w))),
    )
    ids, xy, lcov = slam.landmarks()
    counts = np.asarray(counts, dtype=float).reshape(-1, 3)
    diagnostics = {
        "neff": np.asarray(neff),
        "neff_t": np.asarray(neff_t),
        "resampled": np.asarray(resampled, dtype=bool),
        "common_ancestor_t": np.asarray(ancestor_t, dtype=float),
        "landmarks_min": counts[:, 0],
        "landmarks_mean": counts[:, 1],
        "landmarks_max": counts[:, 2],
        "rejected_nonfinite": np.array(slam.rejected["nonfinite"]),
        "rejected_negative_range": np.array(slam.rejected["negative_range"]),
        "rejected_gate": np.array(slam.rejected["gate"]),
        "rejected_motion": np.array(rejected_motion),
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
