"""``EKFSLAM.run(sequence) -> Estimate``: walk the time-ordered events of a sequence.

Motion and range-bearing events are processed (other streams are not used by EKF-SLAM):

* before every event the filter is propagated from its current time to the event time —
  :class:`Twist` input piecewise with :func:`slamarena.estimators.stepping.twist_pieces`; rows with a
  non-finite velocity are skipped and counted (``rejected_motion``);
* an :class:`Increments` event applies its row (the motion since the previous stamp;
  covariance: the ``increment_cov`` parameter if given, else ``Increments.cov``, else
  ``Noise.increment_cov``);
* a range-bearing event applies its whole observation set with :meth:`EKFSLAM.update`.

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

Diagnostics (arrays):
    nis, nis_dof, nis_t         NIS of every update (per observation, or per batch) and its dof
    assoc_t, assoc_decision     every observation's decision (association.Decision): 0 matched, 1 new, 2 rejected
                                (ambiguous, outside the χ² gate of a labelled row, or an update that is not finite)
    assoc_landmark              id of the landmark matched or created (−1 if rejected)
    assoc_d2                    Mahalanobis d² to the labelled landmark, or to the nearest one (NaN for a new labelled landmark)
    assoc_given_id              the id in the data (also when withheld with use_ids=False)
    looked_ahead_t              the stamp of every row decided by the look-ahead (``window`` > 0)
    rejected_nonfinite, rejected_negative_range, rejected_motion, rejected_indefinite   counts
    lockout_rows, lockout_s, lockout_t0
                                the longest run of consecutive observations that were not new landmarks and were ALL rejected
                                (a gated filter whose covariance no longer admits its observations: it has stopped
                                correcting and drifts), its duration [s] (first to last rejected row) and start; 0, 0, NaN if
                                none was rejected.
"""

from __future__ import annotations

import copy

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.datasets.sequence import Increments, Sequence, Twist

from ..stepping import CLOCKS, last_per_stamp, twist_pieces
from .association import Decision
from .checks import CovarianceError
from .filter import Linearisation

__all__ = ["run_sequence"]


def run_sequence(ekf, sequence: Sequence) -> Estimate:
    ekf.reset(sequence)
    ideal = ekf.params.jacobians == Linearisation.IDEAL
    if ideal:
        if sequence.ground_truth is None or sequence.landmarks is None:
            raise ValueError("jacobians='ideal' needs ground truth poses and landmarks")
        gt = sequence.ground_truth
        ekf.set_truth(landmarks=sequence.landmarks)

    def truth(times: np.ndarray) -> np.ndarray | None:
        """The true poses at ``times`` (jacobians="ideal"), else None."""
        return interpolate_poses(gt.t, gt.poses, np.clip(times, gt.t[0], gt.t[-1])) if ideal and len(times) else None

    motion, rb = sequence.motion, sequence.range_bearing
    table = [e for e in sequence.events() if e.stream in ("motion", "range_bearing")]
    times, poses, covs, steps, nis_t, assoc_t = [], [], [], [], [], []
    rejected_motion = 0
    looked_ahead: list[
        tuple[float, bool]
    ] = []  # per row decided by the look-ahead: its stamp, whether it was matched (else new)

    def predict(filt, chain, t_now: float, t_end: float):
        """Propagate ``filt`` over the motion events ``chain`` from t_now to t_end; (rows used, (poses, covs), where each
        event's stamp falls among the pieces, rows skipped)."""
        if isinstance(motion, Twist):
            v, w, dts, rows = twist_pieces(motion, t_now, t_end, with_rows=True)
            ok = np.isfinite(v) & np.isfinite(w)
            v, w, dts, rows = v[ok], w[ok], dts[ok], rows[ok]
            done = filt.predict_twists(v, w, dts, true_poses=truth(np.maximum(motion.t[rows], t_now)))
            return (
                rows,
                done,
                [event.start for event in chain],
                int((~ok).sum()),
            )  # a Twist row moves the robot from its stamp on
        if isinstance(motion, Increments):
            rows = np.arange(chain[0].start, chain[-1].stop) if chain else np.zeros(0, dtype=int)
            ok = np.all(np.isfinite(motion.delta[rows]), axis=1)
            rows = rows[ok]
            cov = None if motion.cov is None or filt.params.increment_cov is not None else motion.cov[rows]
            starts = np.r_[-np.inf, motion.t][
                rows
            ]  # an increment starts at the previous stamp, the first at the truth's start
            done = filt.predict_increments(motion.delta[rows], cov, true_poses=truth(starts))
            return (
                rows,
                done,
                [event.stop for event in chain],
                int((~ok).sum()),
            )  # an increment has moved the robot by its stamp
        return (
            np.zeros(0, dtype=int),
            (np.zeros((0, 3)), np.zeros((0, 3, 3))),
            [],
            0,
        )  # no motion input: the robot stands still

    # the table as (motion events, the observation set after them or None, the propagation's end)
    blocks, i, t_now = [], 0, sequence.t0
    while i < len(table):
        j = i
        while j < len(table) and table[j].stream == "motion":
            j += 1
        t_end = table[j].t if j < len(table) else (table[j - 1].t if j > i else t_now)
        blocks.append((table[i:j], table[j] if j < len(table) else None, t_now, t_end))
        t_now, i = t_end, j + 1

    def look_ahead(b: int) -> dict[int, int]:
        """The look-ahead (``window`` > 0, association.hypotheses): for each ambiguous row of block b's set in turn, the
        hypothesis whose copy of the filter has the largest log-likelihood over this set and the next ``window`` sets
        (if the filter can carry none of a row's hypotheses through the window, that row and the rest of the set are left to the
        plain association)."""
        decided: dict[int, int] = {}
        z, t = rb.z[blocks[b][1].start : blocks[b][1].stop], blocks[b][1].t
        while (found := ekf.ambiguity(z, decided)) is not None:
            row, options = found
            score = np.full(len(options), -np.inf)
            for k, option in enumerate(options.tolist()):
                trial = copy.deepcopy(ekf)
                start = trial.log_likelihood
                try:
                    trial.update(z, t, {**decided, row: option})
                    for chain, event, t0, t1 in blocks[b + 1 : b + 1 + ekf.params.window]:
                        predict(trial, chain, t0, t1)
                        if event is not None:
                            trial.update(rb.z[event.start : event.stop], event.t)
                except (CovarianceError, ValueError):  # a hypothesis the filter cannot carry through the window
                    continue
                score[k] = trial.log_likelihood - start
            if not np.isfinite(score).any():
                break
            decided[row] = int(options[np.argmax(score)])
            looked_ahead.append((t, decided[row] >= 0))
        return decided

    timer = CLOCKS[ekf.params.step_clock]
    clock = timer()
    for b, (chain, event, t_now, t_end) in enumerate(blocks):
        start = ekf.x[:3].copy(), ekf.robot_cov
        rows, done, upto, skipped = predict(ekf, chain, t_now, t_end)
        rejected_motion += skipped
        # the pose at a motion event's stamp: after the pieces of the rows before it (the start pose if none)
        chain_poses, chain_covs = np.concatenate([start[0][None], done[0]]), np.concatenate([start[1][None], done[1]])
        now = timer()
        for stamp, k in zip(chain, np.searchsorted(rows, upto)):
            times.append(stamp.t)
            poses.append(chain_poses[k])
            covs.append(chain_covs[k])
            steps.append((now - clock) / len(chain))
        clock = now if chain else clock
        if event is not None:
            if ideal:
                ekf.set_truth(pose=truth([event.t])[0])
            n_nis, n_assoc = len(ekf.nis_log), len(ekf.assoc_log)
            ekf.update(rb.z[event.start : event.stop], event.t, look_ahead(b) if ekf.params.window else None)
            nis_t += [event.t] * (len(ekf.nis_log) - n_nis)
            assoc_t += [event.t] * (len(ekf.assoc_log) - n_assoc)
            times.append(event.t)
            poses.append(ekf.x[:3].copy())
            covs.append(ekf.robot_cov)
            now = timer()
            steps.append(now - clock)
            clock = now
    t, steps, poses, covs = last_per_stamp(
        np.asarray(times), np.asarray(steps), np.asarray(poses).reshape(-1, 3), np.asarray(covs).reshape(-1, 3, 3)
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
        "nis_t": np.asarray(nis_t, dtype=float),
        "assoc_t": np.asarray(assoc_t, dtype=float),
        "assoc_decision": log[:, 0].astype(np.int8),
        "assoc_landmark": log[:, 1].astype(np.int64),
        "assoc_d2": log[:, 2],
        "assoc_given_id": log[:, 3].astype(np.int64),
        "rejected_nonfinite": np.array(ekf.rejected["nonfinite"]),
        "rejected_negative_range": np.array(ekf.rejected["negative_range"]),
        "rejected_motion": np.array(rejected_motion),
        "rejected_indefinite": np.array(ekf.rejected["indefinite"]),
    }
    decisions = log[:, 0]
    diagnostics["looked_ahead_t"] = np.array([t for t, _ in looked_ahead], dtype=float)
    lockout = _longest_lockout(diagnostics["assoc_t"], diagnostics["assoc_decision"])
    diagnostics.update(
        lockout_rows=np.array(lockout[0]), lockout_s=np.array(lockout[1]), lockout_t0=np.array(lockout[2])
    )
    meta = {
        "params": ekf.params.canonical(),
        "sequence": sequence.name,
        "n_landmarks": n,
        "tentative": ekf.n_landmarks - n,
        "looked_ahead": len(looked_ahead),
        "looked_ahead_matched": sum(m for _, m in looked_ahead),
        "removed_unconfirmed": ekf.book.removed["unconfirmed"],
        "removed_quality": ekf.book.removed["quality"],
        **{d.name.lower(): int((decisions == d).sum()) for d in Decision},  # "matched", "new", "rejected"
        "noise": {"twist_cov": ekf.M.tolist(), "range_bearing_cov": ekf.R.tolist()},
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
