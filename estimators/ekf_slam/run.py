"""``EKFSLAM.run(sequence) -> Estimate``: walk the time-ordered events of a sequence.

Motion and range-bearing events are processed (other streams are not used by EKF-SLAM), block by block
(:func:`slamarena.estimators.stepping.blocks`: the motion events up to an observation set, then the set):

* before every event the filter is propagated from its current time to the event time —
  :class:`Twist` input piecewise with :func:`slamarena.estimators.stepping.twist_pieces`; rows with a
  non-finite value or one beyond the physical range (``stepping.LIMITS``) are skipped and counted (``rejected_motion``);
* an :class:`Increments` event applies its row (the motion since the previous stamp;
  covariance: the ``increment_cov`` parameter if given, else ``Increments.cov``, else
  ``Noise.increment_cov``);
* a range-bearing event applies its whole observation set with :meth:`EKFSLAM.update`; rows whose range is beyond
  the physical range are left out and counted (``rejected_out_of_range``), so a corrupt row never aborts the run;
  when the sequence states a covariance per observation (``meta["range_bearing_cov_per_observation"]``: the landmark
  extractor's, Victoria Park's reader) and ``range_bearing_cov`` is not given, each row is updated with its own
  (``per_observation_cov``).

The motion between two observation sets is applied as one chain
(:meth:`EKFSLAM.predict_twists` / :meth:`EKFSLAM.predict_increments`: vectorised poses, the
3 × 3 robot recursion per piece, the cross-covariances once), which gives the same result as
piece-by-piece prediction and the pose and covariance after every piece.

Recorded: the filter's pose and 3 × 3 covariance at every stamp, one per stamp — at a motion
event, the state after the pieces of the rows before it (a Twist row moves the robot from its
stamp on, an increment has moved it by its stamp; the start pose and its initial covariance
before the first piece); at an observation set, the posterior. Where events share a stamp the
last, the posterior, is kept (:func:`slamarena.estimators.stepping.last_per_stamp`), so ``t``
increases strictly. Each record carries the time (``step_clock``: wall or CPU) spent since the previous one (a chain's
time is shared evenly by its motion events; records merged at one stamp add theirs). With
``jacobians="ideal"`` the true pose (SE(2)-interpolated ground truth, clipped to its span) is
handed to the filter for every prediction piece (at its start) and update.

Landmarks: the confirmed ones at the end (a tentative landmark, association.LandmarkBook, is not part of the map);
``meta`` counts the tentative ones left and those removed (unconfirmed in time, or by the quality counter).

Look-ahead (``window`` > 0; association.hypotheses): before a set is applied, each ambiguous row without an id is decided
by running a copy of the filter per hypothesis through this set and the next ``window`` sets (their motion included) and
keeping the hypothesis with the largest log-likelihood; the set is then applied with those decisions. ``meta`` counts
the rows so decided (``looked_ahead``) and how many of them were matched (``looked_ahead_matched``; the rest are new).

Self-identification (``self_identify``, off by default; rows without trusted ids only; :mod:`.self_identification`): when the matched
rows' NIS reject the stated noise, the sequence is walked again with the process and measurement noise scaled on a grid
and the most likely walk is returned (the filter left in its state); ``meta["noise_scale"]`` holds the scales of the
walk returned, ``meta["noise_identification"]`` the test and every walk's log-likelihood.

Diagnostics (arrays):
    nis, nis_dof, nis_t         NIS of every update (per observation, or per batch) and its dof
    assoc_t, assoc_decision     every observation's decision (association.Decision): 0 matched, 1 new, 2 rejected
                                (ambiguous, outside the χ² gate of a labelled row, or an update that is not finite)
    assoc_landmark              id of the landmark matched or created (−1 if rejected)
    assoc_d2                    Mahalanobis d² to the labelled landmark, or to the nearest one (NaN for a new labelled landmark)
    assoc_given_id              the id in the data (also when withheld with use_ids=False)
    assoc_weight                a matched row's robust weight (R_j / w_j applied; 1 with robust_update "none"), NaN if not
                                matched
    looked_ahead_t              the stamp of every row decided by the look-ahead (``window`` > 0)
    rejected_nonfinite, rejected_negative_range, rejected_out_of_range, rejected_motion, rejected_indefinite,
    rejected_covariance         counts (the last: rows whose own covariance is not finite and positive definite)
    lockout_rows, lockout_s, lockout_t0
                                the longest run of consecutive observations that were not new landmarks and were ALL rejected
                                (a gated filter whose covariance no longer admits its observations: it has stopped
                                correcting and drifts), its duration [s] (first to last rejected row) and start; 0, 0, NaN if
                                none was rejected.
    landmark_lockout_id, landmark_lockout_rows, landmark_lockout_s
                                the same per landmark (rows grouped by their given id, other landmarks' rows between them
                                not ending a run): the landmark whose re-observations were rejected longest, the rows and
                                seconds of that run; −1, 0, 0 if none. A landmark the filter refuses while it keeps
                                correcting on the others shows here and not in ``lockout_rows``.
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.datasets.sequence import Sequence

from ..stepping import CLOCKS, Block, blocks, last_per_stamp, observation_rows
from . import self_identification
from .association import Decision
from .checks import CovarianceError
from .filter import Linearisation

__all__ = ["run_sequence"]

#: the true poses at some times (jacobians="ideal"), else None
Truth = Callable[[np.ndarray], np.ndarray | None]


def run_sequence(ekf, sequence: Sequence) -> Estimate:
    """``EKFSLAM.run(sequence) -> Estimate`` (bound by the package): the events walked block by block (module docstring);
    without trusted ids and with ``self_identify``, again with scaled noise if the run's innovations reject the stated
    noise (:mod:`.self_identification`)."""
    estimate = _walk(ekf, sequence)
    if ekf.params.self_identify and not ekf.params.use_ids:
        return self_identification.identify(ekf, sequence, estimate, _walk)
    return estimate


def _walk(ekf, sequence: Sequence, q_scale: float = 1.0, r_scale: float = 1.0) -> Estimate:
    """One pass over the sequence from the filter's reset, with the process and measurement noise scaled by q_scale and
    r_scale."""
    ekf.reset(sequence)
    ekf.q_scale, ekf.r_scale = q_scale, r_scale
    truth = _truth(ekf, sequence)
    z_all = sequence.range_bearing.z if sequence.range_bearing is not None else np.zeros((0, 3))
    R_all = _row_covariances(ekf, sequence, len(z_all))
    walk = blocks(sequence, row_cov=ekf.params.increment_cov is None)
    record = _Record(CLOCKS[ekf.params.step_clock])
    looked_ahead: list[tuple[float, bool]] = []  # per row decided by the look-ahead: its stamp, whether it was matched
    rejected = {"motion": 0, "out_of_range": 0}
    for b, block in enumerate(walk):
        start = ekf.x[:3].copy(), ekf.robot_cov
        done = _predict(ekf, block, truth)
        rejected["motion"] += block.motion.rejected
        record.chain(block, start, done)
        if block.observation is not None:
            z, t, far, R = _observations(block, z_all, R_all)
            rejected["out_of_range"] += far
            if truth is not None:
                ekf.set_truth(pose=truth([t])[0])
            decided = _look_ahead(ekf, walk, b, z_all, R_all, truth, looked_ahead) if ekf.params.window else None
            n_nis, n_assoc = len(ekf.nis_log), len(ekf.assoc_log)
            ekf.update(z, t, decided, R)
            record.observation(ekf, t, len(ekf.nis_log) - n_nis, len(ekf.assoc_log) - n_assoc)
    return _estimate(ekf, sequence, record, looked_ahead, rejected)


def _truth(ekf, sequence: Sequence) -> Truth | None:
    """With ``jacobians="ideal"``: hand the true landmarks to the filter and return the true pose at given times
    (SE(2)-interpolated ground truth, clipped to its span); else None."""
    if ekf.params.jacobians != Linearisation.IDEAL:
        return None
    if sequence.ground_truth is None or sequence.landmarks is None:
        raise ValueError("jacobians='ideal' needs ground truth poses and landmarks")
    gt = sequence.ground_truth
    ekf.set_truth(landmarks=sequence.landmarks)
    return lambda times: interpolate_poses(gt.t, gt.poses, np.clip(times, gt.t[0], gt.t[-1])) if len(times) else None


def _predict(filt, block: Block, truth: Truth | None) -> tuple[np.ndarray, np.ndarray]:
    """Propagate ``filt`` over the block's motion as one chain; the (poses, covariances) after each piece (the true
    pose at each piece's start given with jacobians="ideal")."""
    motion = block.motion
    if motion.kind == "none":
        return motion.predict(filt)
    return motion.predict(filt, true_poses=truth(motion.start) if truth is not None else None)


def _row_covariances(ekf, sequence: Sequence, rows: int) -> np.ndarray | None:
    """The sequence's covariance per observation (rows, 2, 2) when it states one (``meta["range_bearing_cov_per_observation"]``,
    e.g. the landmark extractor's) and the filter takes it (``per_observation_cov``, no ``range_bearing_cov`` given);
    else None (the filter's R for every row)."""
    cov = sequence.meta.get("range_bearing_cov_per_observation")
    if cov is None or not ekf.params.per_observation_cov or ekf.params.range_bearing_cov is not None:
        return None
    cov = np.asarray(cov, dtype=float)
    if cov.shape != (rows, 2, 2):
        raise ValueError(
            f"{sequence.name}: meta['range_bearing_cov_per_observation'] must hold one 2 × 2 covariance per "
            f"range-bearing row ({rows}, 2, 2), got {cov.shape}"
        )
    return cov


def _observations(
    block: Block, z_all: np.ndarray, R_all: np.ndarray | None
) -> tuple[np.ndarray, float, int, np.ndarray | None]:
    """The block's observation set (M, 3) without the rows beyond the physical range, its stamp, how many were left
    out, and the rows' own covariances (M, 2, 2) if the sequence states them (else None)."""
    rows, far = observation_rows(block.observation, z_all[:, 0])
    return z_all[rows], block.observation.t, far, None if R_all is None else R_all[rows]


def _look_ahead(
    ekf, walk: list[Block], b: int, z_all: np.ndarray, R_all: np.ndarray | None, truth: Truth | None, looked_ahead: list
) -> dict:
    """The look-ahead (``window`` > 0, association.hypotheses): for each ambiguous row of block b's set in turn, the
    hypothesis whose copy of the filter has the largest log-likelihood over this set and the next ``window`` sets
    (if the filter can carry none of a row's hypotheses through the window, that row and the rest of the set are left
    to the plain association). Appends (stamp, matched) of every decided row to ``looked_ahead``."""
    decided: dict[int, int] = {}
    z, t, _, R = _observations(walk[b], z_all, R_all)
    while (found := ekf.ambiguity(z, decided, R)) is not None:
        row, options = found
        score = np.full(len(options), -np.inf)
        for k, option in enumerate(options.tolist()):
            trial = copy.deepcopy(ekf)
            start = trial.log_likelihood
            try:
                trial.update(z, t, {**decided, row: option}, R)
                for block in walk[b + 1 : b + 1 + ekf.params.window]:
                    _predict(trial, block, truth)
                    if block.observation is not None:
                        z_w, t_w, _, R_w = _observations(block, z_all, R_all)
                        trial.update(z_w, t_w, None, R_w)
            except (CovarianceError, ValueError):  # a hypothesis the filter cannot carry through the window
                continue
            score[k] = trial.log_likelihood - start
        if not np.isfinite(score).any():
            break
        decided[row] = int(options[np.argmax(score)])
        looked_ahead.append((t, decided[row] >= 0))
    return decided


class _Record:
    """The recorded trajectory: a pose, covariance and step time per event, and the stamps of the NIS and association
    logs' entries."""

    def __init__(self, timer):
        self.timer, self.clock = timer, timer()
        self.times, self.poses, self.covs, self.steps, self.nis_t, self.assoc_t = [], [], [], [], [], []

    def chain(self, block: Block, start: tuple[np.ndarray, np.ndarray], done: tuple[np.ndarray, np.ndarray]) -> None:
        """The pose at each motion event's stamp: after the pieces before it (the chain's start pose if none); the
        chain's time is shared evenly by its events."""
        poses, covs = np.concatenate([start[0][None], done[0]]), np.concatenate([start[1][None], done[1]])
        now = self.timer()
        for event, k in zip(block.chain, block.motion.at_event):
            self.times.append(event.t)
            self.poses.append(poses[k])
            self.covs.append(covs[k])
            self.steps.append((now - self.clock) / len(block.chain))
        self.clock = now if block.chain else self.clock

    def observation(self, ekf, t: float, n_nis: int, n_assoc: int) -> None:
        """The posterior after an observation set at t, which added n_nis NIS values and n_assoc decisions."""
        self.nis_t += [t] * n_nis
        self.assoc_t += [t] * n_assoc
        self.times.append(t)
        self.poses.append(ekf.x[:3].copy())
        self.covs.append(ekf.robot_cov)
        now = self.timer()
        self.steps.append(now - self.clock)
        self.clock = now


def _estimate(ekf, sequence: Sequence, record: _Record, looked_ahead: list, rejected: dict) -> Estimate:
    """The :class:`Estimate`: one pose per stamp, the confirmed landmarks, the diagnostics and meta."""
    t, steps, poses, covs = last_per_stamp(
        np.asarray(record.times),
        np.asarray(record.steps),
        np.asarray(record.poses).reshape(-1, 3),
        np.asarray(record.covs).reshape(-1, 3, 3),
    )
    confirmed = np.flatnonzero(ekf.confirmed)  # tentative landmarks (association.LandmarkBook) are not part of the map
    n = confirmed.size
    P = ekf.P
    base = 3 + 2 * confirmed
    landmark_cov = P[base[:, None, None] + np.arange(2)[:, None], base[:, None, None] + np.arange(2)[None, :]]
    nis = np.array(ekf.nis_log, dtype=float).reshape(-1, 2)
    log = np.array(ekf.assoc_log, dtype=float).reshape(-1, 4)
    diagnostics = {
        "nis": nis[:, 0],
        "nis_dof": nis[:, 1].astype(np.int64),
        "nis_t": np.asarray(record.nis_t, dtype=float),
        "assoc_t": np.asarray(record.assoc_t, dtype=float),
        "assoc_decision": log[:, 0].astype(np.int8),
        "assoc_landmark": log[:, 1].astype(np.int64),
        "assoc_d2": log[:, 2],
        "assoc_given_id": log[:, 3].astype(np.int64),
        "rejected_nonfinite": np.array(ekf.rejected["nonfinite"]),
        "rejected_negative_range": np.array(ekf.rejected["negative_range"]),
        "rejected_out_of_range": np.array(rejected["out_of_range"]),
        "rejected_motion": np.array(rejected["motion"]),
        "rejected_indefinite": np.array(ekf.rejected["indefinite"]),
        "rejected_covariance": np.array(ekf.rejected["covariance"]),
        "assoc_weight": np.asarray(ekf.weight_log, dtype=float),
    }
    decisions = log[:, 0]
    diagnostics["looked_ahead_t"] = np.array([t for t, _ in looked_ahead], dtype=float)
    lockout = _longest_lockout(diagnostics["assoc_t"], diagnostics["assoc_decision"])
    landmark_lockout = _longest_landmark_lockout(
        diagnostics["assoc_t"], diagnostics["assoc_decision"], diagnostics["assoc_given_id"]
    )
    diagnostics.update(
        lockout_rows=np.array(lockout[0]),
        lockout_s=np.array(lockout[1]),
        lockout_t0=np.array(lockout[2]),
        landmark_lockout_id=np.array(landmark_lockout[0]),
        landmark_lockout_rows=np.array(landmark_lockout[1]),
        landmark_lockout_s=np.array(landmark_lockout[2]),
    )
    meta = {
        "params": ekf.params.canonical(),
        "sequence": sequence.name,
        "n_landmarks": n,
        "tentative": ekf.n_landmarks - n,
        "anchors_reset": ekf.anchors_reset,
        "looked_ahead": len(looked_ahead),
        "looked_ahead_matched": sum(m for _, m in looked_ahead),
        "removed_unconfirmed": ekf.book.removed["unconfirmed"],
        "removed_quality": ekf.book.removed["quality"],
        **{d.name.lower(): int((decisions == d).sum()) for d in Decision},  # "matched", "new", "rejected"
        "noise": {"twist_cov": ekf.M.tolist(), "range_bearing_cov": ekf.R.tolist()},
        "noise_scale": {"q": ekf.q_scale, "r": ekf.r_scale},
    }
    return Estimate(
        method="ekf_slam" if ekf.params.jacobians == Linearisation.STANDARD else f"ekf_slam_{ekf.params.jacobians}",
        t=t,
        poses=poses,
        pose_cov=covs,
        landmark_ids=ekf.landmark_ids[confirmed],
        landmarks=ekf.x[3:].reshape(-1, 2)[confirmed],
        landmark_cov=landmark_cov.reshape(-1, 2, 2),
        step_time=steps,
        diagnostics=diagnostics,
        meta=meta,
    )


def _longest_lockout(t: np.ndarray, decision: np.ndarray) -> tuple[int, float, float]:
    """(rows, duration [s], start [s]) of the longest run of consecutive non-new observations that were all rejected."""
    t, rejected = t[decision != Decision.NEW], decision[decision != Decision.NEW] == Decision.REJECTED
    if not rejected.any():
        return 0, 0.0, float("nan")
    edges = np.diff(np.r_[0, rejected.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)  # runs [start, stop)
    k = int(np.argmax(stops - starts))
    return int(stops[k] - starts[k]), float(t[stops[k] - 1] - t[starts[k]]), float(t[starts[k]])


def _longest_landmark_lockout(t: np.ndarray, decision: np.ndarray, given_id: np.ndarray) -> tuple[int, int, float]:
    """(id, rows, duration [s]) of the longest run of one landmark's consecutive non-new observations that were all
    rejected, its rows taken in time order with every other landmark's rows left out; (−1, 0, 0.0) if none."""
    keep = decision != Decision.NEW
    t, ids, rejected = t[keep], given_id[keep], decision[keep] == Decision.REJECTED
    if not rejected.any():
        return -1, 0, 0.0
    order = np.lexsort((np.arange(len(ids)), ids))  # by landmark, then in time
    t, ids, rejected = t[order], ids[order], rejected[order]
    same = np.r_[False, ids[1:] == ids[:-1]]
    starts = rejected & ~(same & np.r_[False, rejected[:-1]])  # a rejected row whose predecessor does not continue it
    run = np.cumsum(starts) * rejected  # run number of each rejected row (1, 2, …), 0 elsewhere
    rows = np.bincount(run)[1:]
    k = int(np.argmax(rows)) + 1
    members = np.flatnonzero(run == k)
    return int(ids[members[0]]), int(rows[k - 1]), float(t[members[-1]] - t[members[0]])
