"""``EKFSLAM.run(sequence) -> Estimate``: walk the time-ordered events of a sequence.

Motion and range-bearing events are processed (other streams are not used by EKF-SLAM):

* before every event the filter is propagated from its current time to the event time —
  :class:`Twist` input piecewise with :func:`estimators.stepping.twist_pieces`; rows with a
  non-finite velocity are skipped and counted (``rejected_motion``);
* an :class:`Increments` event applies its row with :meth:`EKFSLAM.predict_increment`
  (covariance from ``Increments.cov``, else ``Noise.increment_cov``);
* a range-bearing event applies its whole observation set with :meth:`EKFSLAM.update`.

One pose and its 3 × 3 covariance are recorded per processed event, with the wall time spent
since the previous record. With ``jacobians="ideal"`` the true pose (SE(2)-interpolated ground
truth) is handed to the filter before every prediction piece and update.

Diagnostics (arrays):
    nis, nis_dof, nis_t         NIS of every update (per observation, or per batch) and its dof
    assoc_t, assoc_decision     every observation's decision: 0 matched, 1 new, 2 rejected
    assoc_landmark              id of the landmark matched or created (−1 if rejected)
    assoc_d2                    Mahalanobis d² to the nearest landmark (NaN when associated by id)
    assoc_given_id              the id in the data (also when withheld with use_ids=False)
    rejected_nonfinite, rejected_negative_range, rejected_motion, rejected_indefinite   counts
"""
from __future__ import annotations

import time

import numpy as np

from datasets.estimate import Estimate
from datasets.geometry import interpolate_poses
from datasets.sequence import Increments, Sequence, Twist

from ..stepping import twist_pieces

__all__ = ["run_sequence"]


def run_sequence(ekf, sequence: Sequence) -> Estimate:
    ekf.reset(sequence)
    ideal = ekf.params["jacobians"] == "ideal"
    if ideal:
        if sequence.ground_truth is None or sequence.landmarks is None or not ekf.use_ids:
            raise ValueError("jacobians='ideal' needs ground truth poses and landmarks and known association (use_ids=True)")
        gt = sequence.ground_truth
        ekf.set_truth(landmarks=sequence.landmarks)

    def truth_at(t: float) -> None:
        if ideal:
            ekf.set_truth(pose=interpolate_poses(gt.t, gt.poses, np.array([t]))[0])

    motion, rb = sequence.motion, sequence.range_bearing
    times, poses, covs, steps, nis_t, assoc_t = [], [], [], [], [], []
    rejected_motion = 0
    t_now = sequence.t0
    clock = time.perf_counter()
    for event in sequence.events():
        if event.stream not in ("motion", "range_bearing"):
            continue
        if isinstance(motion, Twist):
            v, w, dts = twist_pieces(motion, t_now, event.t)
            t_piece = t_now
            for vk, wk, dtk in zip(v, w, dts):
                if np.isfinite(vk) and np.isfinite(wk):
                    truth_at(t_piece)
                    ekf.predict((vk, wk), dtk)
                else:
                    rejected_motion += 1
                t_piece += dtk
        t_now = event.t
        if event.stream == "motion" and isinstance(motion, Increments):
            for k in range(event.start, event.stop):
                if np.all(np.isfinite(motion.delta[k])):
                    truth_at(t_now)
                    ekf.predict_increment(motion.delta[k], None if motion.cov is None else motion.cov[k])
                else:
                    rejected_motion += 1
        elif event.stream == "range_bearing":
            truth_at(t_now)
            n_nis, n_assoc = len(ekf.nis_log), len(ekf.assoc_log)
            ekf.update(rb.z[event.start:event.stop])
            nis_t += [t_now] * (len(ekf.nis_log) - n_nis)
            assoc_t += [t_now] * (len(ekf.assoc_log) - n_assoc)
        times.append(t_now)
        poses.append(ekf.x[:3].copy())
        covs.append(ekf.P[:3, :3].copy())
        now = time.perf_counter()
        steps.append(now - clock)
        clock = now

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
        "params": ekf.params, "sequence": sequence.name, "n_landmarks": n,
        "matched": int((decisions == 0).sum()), "new": int((decisions == 1).sum()), "rejected": int((decisions == 2).sum()),
        "noise": {"twist_cov": ekf.M.tolist(), "range_bearing_cov": ekf.R.tolist()},
    }
    return Estimate(
        method="ekf_slam" if ekf.params["jacobians"] == "standard" else f"ekf_slam_{ekf.params['jacobians']}",
        t=np.asarray(times), poses=np.asarray(poses).reshape(-1, 3), pose_cov=np.asarray(covs).reshape(-1, 3, 3),
        landmark_ids=ekf.landmark_ids, landmarks=ekf.x[3:].reshape(-1, 2).copy(), landmark_cov=landmark_cov.reshape(-1, 2, 2),
        step_time=np.asarray(steps), diagnostics=diagnostics, meta=meta,
    )
