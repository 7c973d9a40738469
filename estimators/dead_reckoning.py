"""Dead reckoning: integrate the motion input alone; the baseline row of every table.

Model
-----
State ``x = (x, y, θ)`` (3,), covariance ``P`` (3, 3), world frame. Start: ``x_0 =
sequence.start_pose`` and ``P_0 = diag(initial_sigma²)`` (default 0: the start pose is the frame).

Twist input ``u_k = (v_k, ω_k)`` held for ``dt_k`` (``Noise.twist_cov = Q`` (2, 2), the
covariance of one row's velocity error)::

    x_{k+1} = x_k ⊕ δ(u_k, dt_k)                       (motion model, EULER or ARC)
    P_{k+1} = G_k P_k G_kᵀ + V_k Q V_kᵀ                 G_k = ∂x'/∂x (3, 3), V_k = ∂x'/∂u (3, 2)

Increments input ``δ_k`` (body frame, covariance ``C_k`` = ``Increments.cov[k]`` or
``Noise.increment_cov``)::

    x_{k+1} = x_k ⊕ δ_k
    P_{k+1} = J_x P_k J_xᵀ + J_δ C_k J_δᵀ               (models.compose_jacobians)

Both Jacobians with respect to the state have the form ``G_k = [[I₂, g_k], [0, 1]]``, so the
recursion has a closed form computed with prefix sums instead of a loop
(:func:`slamarena.estimators.models.propagate_covariance`, checked against the literal recursion in the tests).

Output poses
------------
Twist input (the usual case: each row ends where the next starts, or earlier — gaps are
standing still): one pose at every row stamp ``t_k`` and one at the end of the last row,
``K + 1`` poses, the whole trajectory in one vectorised ``MotionModel.integrate`` call. If
rows overlap (a row's ``dt`` reaches past the next stamp), the replay follows
``slamarena.estimators.stepping.twist_pieces`` between stamps, as a filter would. Increments input:
one pose after each row at its stamp (``K`` poses), ``slamarena.datasets.geometry.accumulate``.

``step_time`` is the wall time of the whole integration divided evenly over the poses (the
work is one vectorised pass, so there is no per-pose time to measure).
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
from pydantic import NonNegativeFloat

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import accumulate
from slamarena.datasets.sequence import Increments, Sequence, Twist
from slamarena.params import Field, Params

from .models import MOTION_MODELS, compose_chain, noise_in_force, propagate_covariance
from .stepping import twist_pieces

__all__ = ["DeadReckoning", "DeadReckoningParams"]


class DeadReckoningParams(Params):
    """Parameters of :class:`DeadReckoning`."""

    motion_model: Literal["arc", "euler"] = Field(
        "arc",
        description="motion model of Twist input (estimators.models): exact constant-twist arc or the notes' Euler step",
    )
    propagate_covariance: bool = Field(True, description="compute pose_cov when the sequence states its motion noise")
    initial_sigma: tuple[NonNegativeFloat, NonNegativeFloat, NonNegativeFloat] = Field(
        (0.0, 0.0, 0.0),
        description="standard deviations (σx [m], σy [m], σθ [rad]) of the start pose; 0: the start pose is the frame",
    )


class DeadReckoning:
    """Integrate the motion input with the motion model; covariance when the noise is known (:class:`DeadReckoningParams`)."""

    Params = DeadReckoningParams

    def __init__(self, params: DeadReckoningParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        self.model = MOTION_MODELS[self.params.motion_model]
        self.P0 = np.diag(np.square(self.params.initial_sigma))

    def run(self, sequence: Sequence) -> Estimate:
        motion = sequence.motion
        if motion is None or not len(motion):
            raise ValueError(f"dead reckoning needs a motion input; sequence {sequence.name!r} has none")
        start = time.perf_counter()
        if isinstance(motion, Twist):
            t, poses, pose_cov, rejected = self._run_twist(motion, sequence)
        else:
            t, poses, pose_cov, rejected = self._run_increments(motion, sequence)
        elapsed = time.perf_counter() - start
        return Estimate(
            method="dead_reckoning",
            t=t,
            poses=poses,
            pose_cov=pose_cov,
            step_time=np.full(t.shape, elapsed / max(len(t), 1)),
            diagnostics={"rejected_motion_rows": np.array(rejected)},
            meta={"params": self.params.canonical(), "input": type(motion).__name__, "rejected_motion_rows": rejected},
        )

    # ---------------------------------------------------------------- Twist
    def _run_twist(self, twist: Twist, sequence: Sequence):
        clean, rejected = _finite_twist(twist)
        if np.any(twist.t[:-1] + twist.dt[:-1] > twist.t[1:]):  # overlapping rows
            v, omega, dt, owner = _replay_pieces(clean)
        else:
            v, omega, dt, owner = clean.v, clean.omega, clean.dt, np.arange(len(twist))
        t = np.append(twist.t, twist.t[-1] + twist.dt[-1])
        piece_poses = self.model.integrate(sequence.start_pose, v, omega, dt)
        # the pose at stamp k + 1 is the pose after the last piece owned by rows ≤ k
        last_piece = np.searchsorted(owner, np.arange(len(twist)), side="right")
        poses = np.vstack([piece_poses[:1], piece_poses[last_piece]])
        pose_cov = None
        Q = sequence.noise.twist_cov
        if self.params.propagate_covariance and Q is not None:
            G, V = self.model.jacobians(piece_poses[:-1], v, omega, dt)
            P = propagate_covariance(self.P0, G, V @ Q @ np.swapaxes(V, 1, 2))
            pose_cov = np.concatenate([P[:1], P[last_piece]])
        return t, poses, pose_cov, rejected

    # ---------------------------------------------------------------- Increments
    def _run_increments(self, inc: Increments, sequence: Sequence):
        delta = inc.delta.copy()
        bad = ~np.isfinite(delta).all(axis=1)
        delta[bad] = 0.0
        pose_cov = None
        C = noise_in_force(inc.cov, sequence, "increment_cov")  # the rows' own, else the stated
        if self.params.propagate_covariance and C is not None:
            C = np.broadcast_to(C, (len(inc), 3, 3)).copy()
            C[bad] = 0.0
            poses, pose_cov = compose_chain(sequence.start_pose, self.P0, delta, C)
        else:
            poses = accumulate(sequence.start_pose, delta)[1:]
        return inc.t.copy(), poses, pose_cov, int(bad.sum())


def _finite_twist(twist: Twist) -> tuple[Twist, int]:
    """The input with non-finite rows (rejected, counted) replaced by standing still."""
    bad = ~(np.isfinite(twist.v) & np.isfinite(twist.omega))
    clean = Twist(t=twist.t, v=np.where(bad, 0.0, twist.v), omega=np.where(bad, 0.0, twist.omega), dt=twist.dt)
    return clean, int(bad.sum())


def _replay_pieces(twist: Twist) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pieces carrying the state between consecutive stamps (``twist_pieces``) and each piece's row."""
    ends = np.append(twist.t[1:], twist.t[-1] + twist.dt[-1])
    pieces = [twist_pieces(twist, a, b) for a, b in zip(twist.t, ends)]
    owner = np.concatenate([np.full(len(p[0]), k) for k, p in enumerate(pieces)])
    v, omega, dt = (np.concatenate([p[i] for p in pieces]) for i in range(3))
    return v, omega, dt, owner
