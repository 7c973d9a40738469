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

One pose and its 3 × 3 covariance are recorded per processed event, with the wall time spent
since the previous record (a chain's time is shared evenly by its motion events). With
``jacobians="ideal"`` the true pose (SE(2)-interpolated ground truth, clipped to its span) is
handed to the filter for every prediction piece and update.

Diagnostics (arrays):
    nis, nis_dof, nis_t         NIS of every update (per observation, or per batch) and its dof
    assoc_t, assoc_decision     every observation's decision (association.Decision): 0 matched, 1 new, 2 rejected
    assoc_landmark              id of the landmark matched or created (−1 if rejected)
    assoc_d2                    Mahalanobis d² to the nearest landmark (NaN when associated by id)
    assoc_given_id              the id in the data (also when withheld with use_ids=False)
    rejected_nonfinite, rejected_negative_range, rejected_motion, rejected_indefinite   counts
"""
from __future__ import annotations

import time

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses
from slamarena.datasets.sequence import Increments, Sequence, Twist

from ..stepping import twist_pieces
from .association import Decision
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

    motion, rb = sequence.motion, sequence.range_bearing
    table = [e for e in sequence.events() if e.stream in ("motion", "range_bearing")]
    times, poses, covs, steps, nis_t, assoc_t = [], [], [], [], [], []
    rejected_motion = 0
    t_now = sequence.t0
    clock = time.perf_counter()
    i = 0
    while i < len(table):
        # a chain: the motion events up to (and the propagation to) the next observation set
        j = i
        while j < len(table) and table[j].stream == "motion":
            j += 1
        chain = table[i:j]
        t_end = table[j].t if j < len(table) else (chain[-1].t if chain else t_now)
        if isinstance(motion, Twist):
            v, w, dts = twist_pieces(motion, t_now, t_end)
            ends = t_now + np.cumsum(dts)
            ok = np.isfinite(v) & np.isfinite(w)
            rejected_motion += int((~ok).sum())
            starts = (ends - dts)[ok]
            truth = interpolate_poses(gt.t, gt.poses, np.clip(starts, gt.t[0], gt.t[-1])) if ideal and ok.any() else None
            done = ekf.predict_twists(v[ok], w[ok], dts[ok], true_poses=truth) if ok.any() else None
            ends = ends[ok]
        elif isinstance(motion, Increments):
            rows = np.arange(chain[0].start, chain[-1].stop) if chain else np.zeros(0, dtype=int)
            ok = np.all(np.isfinite(motion.delta[rows]), axis=1)
            rejected_motion += int((~ok).sum())
            rows = rows[ok]
            truth = interpolate_poses(gt.t, gt.poses, np.clip(motion.t[rows], gt.t[0], gt.t[-1])) if ideal and rows.size else None
            cov = None if motion.cov is None or ekf.params.increment_cov is not None else motion.cov[rows]
            done = ekf.predict_increments(motion.delta[rows], cov, true_poses=truth) if rows.size else None
            ends = motion.t[rows]
        else:  # no motion input: the robot stands still
            done, ends = None, np.zeros(0)
        before_pose, before_cov = (poses[-1], covs[-1]) if poses else (ekf.x[:3].copy(), ekf.P[:3, :3].copy())
        now = time.perf_counter()
        for event in chain:  # poses at the motion events, from the chain
            k = int(np.searchsorted(ends, event.t + 1e-9, side="right"))
            times.append(event.t)
            poses.append(done[0][k - 1] if k else before_pose)
            covs.append(done[1][k - 1] if k else before_cov)
            steps.append((now - clock) / max(len(chain), 1))
        clock = now if chain else clock
        t_now = t_end
        if j < len(table):
            event = table[j]
            if ideal:
                ekf.set_truth(pose=interpolate_poses(gt.t, gt.poses, np.clip([event.t], gt.t[0], gt.t[-1]))[0])
            n_nis, n_assoc = len(ekf.nis_log), len(ekf.assoc_log)
            ekf.update(rb.z[event.start:event.stop])
            nis_t += [event.t] * (len(ekf.nis_log) - n_nis)
            assoc_t += [event.t] * (len(ekf.assoc_log) - n_assoc)
            times.append(event.t)
            poses.append(ekf.x[:3].copy())
            covs.append(ekf.P[:3, :3].copy())
            now = time.perf_counter()
            steps.append(now - clock)
            clock = now
        i = j + 1

    n = ekf.n_landmarks
    P = ekf.P
    base = 3 + 2 * np.arange(n)
    landmark_cov = P[base[:, None, None] + np.arange(2)[:, None], base[:, None, None] + np.arange(2)[None, :]]
    nis = np.array(ekf.nis_log, dtype=float).reshape(-1, 2)
    log = np.array(ekf.assoc_log, dtype=float).reshape(-1, 4)
    diagnostics = {
        "nis": nis[:, 0], "nis_dof": nis[:, 1].astype(np.int64), "nis_t": np.asarray(nis_t, dtype=float),
        "assoc_t": np.asarray(assoc_t, dtype=float), "assoc_decision": log[:, 0].astype(np.int8),
        "assoc_landmark": log[:, 1].astype(np.int64), "assoc_d2": log[:, 2], "assoc_given_id": log[:, 3].astype(np.int64),
        "rejected_nonfinite": np.array(ekf.rejected["nonfinite"]), "rejected_negative_range": np.array(ekf.rejected["negative_range"]),
        "rejected_motion": np.array(rejected_motion), "rejected_indefinite": np.array(ekf.rejected["indefinite"]),
    }
    decisions = log[:, 0]
    meta = {
        "params": ekf.params.canonical(), "sequence": sequence.name, "n_landmarks": n,
        **{d.name.lower(): int((decisions == d).sum()) for d in Decision},  # "matched", "new", "rejected"
        "noise": {"twist_cov": ekf.M.tolist(), "range_bearing_cov": ekf.R.tolist()},
    }
    return Estimate(
        method="ekf_slam" if ekf.params.jacobians == Linearisation.STANDARD else f"ekf_slam_{ekf.params.jacobians}",
        t=np.asarray(times), poses=np.asarray(poses).reshape(-1, 3), pose_cov=np.asarray(covs).reshape(-1, 3, 3),
        landmark_ids=ekf.landmark_ids, landmarks=ekf.x[3:].reshape(-1, 2).copy(), landmark_cov=landmark_cov.reshape(-1, 2, 2),
        step_time=np.asarray(steps), diagnostics=diagnostics, meta=meta,
    )
