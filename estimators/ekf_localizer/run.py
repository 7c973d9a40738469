"""``EKFLocalizer.run(sequence) -> Estimate``: walk ``Sequence.events()`` through the localizer's timed steps.

The filter starts at ``sequence.t0`` with the noise in force for the sequence (``use_sequence_noise``: the noise it
states), at the start pose the sequence states (its ``initial_pose`` or ground truth) with ``initial_cov``; a sequence
that states none (MRCLAM Dataset 1) starts at the pose fitted to its first range-bearing rows to known landmarks, with
the fit's covariance (:mod:`.start`), else at the origin with ``initial_cov``; ``meta["start"]`` says which. Used streams: the motion stream
(a Twist is followed row by row, :meth:`EKFLocalizer.follow`; Increments rows are applied at their
stamps with the row's, the sequence's or ``increment_cov`` covariance), GPS, heading, and the
range-bearing and beacon-range rows whose id is in ``sequence.landmarks`` (the others are counted as
``unknown_landmark`` / ``unknown_beacon``); scans are ignored. Events come in time order, so no
input is replayed. The events are walked as the landmark filters walk them
(:func:`slamarena.estimators.stepping.blocks`: each block's motion events, then its observation event), one
:meth:`EKFLocalizer._step` each; the filter itself rejects and counts the bad rows (``rejected``).

One pose and covariance are recorded per stamp — the posterior after every event at that stamp
(:func:`slamarena.estimators.stepping.last_per_stamp`) — with the wall time of its steps. ``Estimate.meta``
holds the parameters (``params``: :meth:`Params.canonical`), the noise in force (``noise``: the
parameters ``use_sequence_noise`` replaces, as used), ``rejected`` (sensor → reason → count) and
``recoveries`` (sensor → count); ``Estimate.diagnostics`` the arrays of :mod:`.diagnostics`.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sequence import Event, Increments, Sequence, Twist

from ..stepping import blocks, last_per_stamp
from .filter import SEQUENCE_NOISE
from .start import StartSearch

if TYPE_CHECKING:
    from .filter import EKFLocalizer

__all__ = ["run_sequence"]

#: the observation streams the localizer uses (scans are not)
_OBSERVED = ("range_bearing", "beacon_ranges", "gps", "heading")


def run_sequence(localizer: EKFLocalizer, sequence: Sequence) -> Estimate:
    """``EKFLocalizer.run(sequence) -> Estimate`` (bound by the package): one timed step per event (module docstring)."""
    localizer.use_noise_of(sequence)
    pose, cov, start = _start(localizer, sequence)
    localizer.reset(pose, cov, t=sequence.t0)
    if isinstance(sequence.motion, Twist):
        localizer.follow(sequence.motion)
    n = sequence.event_table()[0].size
    times, poses, covs, step_time = np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3)), np.empty(n)
    k = 0
    for block in blocks(sequence, observe=_OBSERVED):
        for event in block.chain if block.observation is None else [*block.chain, block.observation]:
            tic = time.perf_counter()
            kind, value = _input(localizer, sequence, event)
            localizer._step(event.t, kind, value)  # in time order: a step, never a replay
            step_time[k] = time.perf_counter() - tic
            times[k], poses[k], covs[k] = event.t, localizer.x, localizer.P
            k += 1
    record = localizer.record()
    t, steps, poses, covs = last_per_stamp(times[:k], step_time[:k], poses[:k], covs[:k])
    return Estimate(
        method="ekf_localizer",
        t=t,
        poses=poses,
        pose_cov=covs,
        step_time=steps,
        diagnostics=record.arrays(),
        meta={
            "sequence": sequence.name,
            "params": localizer.params.canonical(),
            "noise": {name: getattr(localizer.noise, name) for name in SEQUENCE_NOISE},
            "rejected": record.rejected,
            "recoveries": record.recoveries,
            "start": start,
        },
    )


def _start(localizer: EKFLocalizer, sequence: Sequence) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """The start pose, its covariance (None: ``initial_cov``) and how it was found (module docstring)."""
    if sequence.initial_pose is not None or (sequence.ground_truth is not None and len(sequence.ground_truth)):
        return sequence.start_pose, None, {"from": "sequence"}
    if sequence.range_bearing is not None and sequence.landmarks is not None:
        search = StartSearch(sequence.landmarks, localizer.R["landmark"], localizer.gate["landmark"])
        dead_reckoning = type(localizer)(localizer.noise)  # the localizer's own prediction, never updated
        dead_reckoning.reset(np.zeros(3), np.zeros((3, 3)), t=sequence.t0)
        if isinstance(sequence.motion, Twist):
            dead_reckoning.follow(sequence.motion)
        rb = sequence.range_bearing
        for block in blocks(sequence, observe=("range_bearing",)):
            for event in block.chain:
                dead_reckoning._step(event.t, *_input(dead_reckoning, sequence, event))
            if block.observation is None:
                continue
            event = block.observation
            dead_reckoning._advance(event.t)
            z = np.column_stack([rb.range[event.start : event.stop], rb.bearing[event.start : event.stop]])
            found = search.add(dead_reckoning.x, dead_reckoning.P, rb.landmark_id[event.start : event.stop], z)
            if found is not None:
                info = {"from": "landmarks", "rows": len(search.ids), "until": event.t, "dropped": search.dropped}
                return found[0], found[1], info
    return np.zeros(3), None, {"from": "origin (the sequence states no start pose and no landmark fixed one)"}


def _input(localizer: EKFLocalizer, sequence: Sequence, event: Event) -> tuple[str, object]:
    """The timed input (kind, value) of ``event``; unknown landmark and beacon ids are counted and left out."""
    start, stop = event.start, event.stop
    if event.stream == "motion":
        motion = sequence.motion
        if isinstance(motion, Increments):
            return "increment", (motion.delta[start], None if motion.cov is None else motion.cov[start])
        return "twist", None  # the followed stream: propagating to the stamp is the whole step
    if event.stream == "gps":
        return "gps", sequence.gps.xy[start]
    if event.stream == "heading":
        return "imu", sequence.heading.yaw[start]
    if event.stream == "beacon_ranges":
        br = sequence.beacon_ranges
        rows, xy = _known(localizer, sequence, br.beacon_id[start:stop], "beacon")
        return "beacon", np.column_stack([br.range[start:stop][rows], xy])
    rb = sequence.range_bearing
    rows, xy = _known(localizer, sequence, rb.landmark_id[start:stop], "landmark")
    return "landmark", np.column_stack([rb.range[start:stop][rows], rb.bearing[start:stop][rows], xy])


def _known(localizer: EKFLocalizer, sequence: Sequence, ids: np.ndarray, sensor: str) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``ids`` in ``sequence.landmarks`` and their positions; the others are counted."""
    lm = sequence.landmarks
    known = np.isin(ids, lm.ids) if lm is not None else np.zeros(ids.shape, dtype=bool)
    unknown = int((~known).sum())
    if unknown:
        localizer._log.reject(sensor, f"unknown_{sensor}", unknown)
    rows = np.flatnonzero(known)
    return rows, np.array([lm.position(i) for i in ids[rows]]).reshape(-1, 2)
