"""The EKF localizer's lagged-data history: snapshots, rewind and replay of delayed input.

After each timed input a :class:`Snapshot` (t, kind, value, x, P, the gate's rejection streaks and
the step's diagnostics) joins a history covering ``history_length`` seconds: the newest snapshot at
or before ``t − history_length`` stays as the anchor, the older ones leave (their diagnostics become
final). An input older than the filter's time rewinds the history to the last snapshot at or before
its stamp; the filter restores that state and replays the delayed input and then the inputs cut
from the history, in time order (robot_localization's lagged-data smoothing). An input older than
the whole history (:attr:`History.start`) cannot be replayed and is rejected (``too_old``).

The twist commands of timed input are logged here too, as long as they reach into the history:
a replay propagates with the commands that were in force, including ones that arrived late.
"""

from __future__ import annotations

from bisect import bisect_right, insort
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from slamarena.datasets.sequence import Twist

from .diagnostics import Diagnostics

__all__ = ["History", "Snapshot"]


@dataclass
class Snapshot:
    """The filter right after input (t, kind, value) was applied, and what that step recorded."""

    t: float
    kind: str
    value: object
    x: np.ndarray
    P: np.ndarray
    streak: dict[str, tuple]  # per sensor: its consecutive gate rejections, their sources, the suspect sources
    diagnostics: Diagnostics


class History:
    """Snapshots of the last ``length`` seconds [s] and the twist commands in force over them."""

    def __init__(self, length: float):
        self.length = length
        self.snapshots: list[Snapshot] = []
        self.times: list[float] = []
        self.commands: list[tuple[float, float, float, float]] = []  # (t, v, ω, dt) in time order
        self._twist: Twist | None = None

    @property
    def start(self) -> float:
        """Time of the oldest snapshot: input before it is too old to replay."""
        return self.times[0]

    def push(self, snapshot: Snapshot) -> list[Snapshot]:
        """Add the newest snapshot; drop (and return) those before the anchor, and the commands that end before it."""
        self.snapshots.append(snapshot)
        self.times.append(snapshot.t)
        keep_from = bisect_right(self.times, snapshot.t - self.length) - 1  # the anchor
        if keep_from <= 0:
            return []
        dropped = self.snapshots[:keep_from]
        del self.snapshots[:keep_from]
        del self.times[:keep_from]
        anchor = self.times[0]
        if self.commands and self.commands[0][0] + self.commands[0][3] < anchor:
            self.commands = [c for c in self.commands if c[0] + c[3] >= anchor]
            self._twist = None
        return dropped

    def rewind(self, t: float, kind: str, value) -> tuple[Snapshot, list[tuple[float, str, object]]]:
        """Cut the history after the newest snapshot at or before ``t`` (≥ :attr:`start`).

        Returns that snapshot (the state to restore) and the inputs to apply from it, in time
        order: the delayed input (t, kind, value), then those of the snapshots cut."""
        k = bisect_right(self.times, t) - 1
        anchor, later = self.snapshots[k], self.snapshots[k + 1 :]
        del self.snapshots[k + 1 :]
        del self.times[k + 1 :]
        return anchor, [(t, kind, value), *((s.t, s.kind, s.value) for s in later)]

    def log_command(self, t: float, v: float, omega: float, dt: float) -> None:
        """Remember the twist command (v, ω) held for dt from t, in time order."""
        insort(self.commands, (t, v, omega, dt))
        self._twist = None

    def twist(self) -> Twist | None:
        """The logged commands as a Twist (None before the first)."""
        if self._twist is None and self.commands:
            t, v, omega, dt = (np.array(c) for c in zip(*self.commands))
            self._twist = Twist(t=t, v=v, omega=omega, dt=dt)
        return self._twist

    def diagnostics(self) -> Iterator[Diagnostics]:
        """The records of the steps still held (not final: a replay may redo them)."""
        return (s.diagnostics for s in self.snapshots)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times (H,), states (H, 3), covariances (H, 3, 3) of the snapshots held."""
        return (
            np.array(self.times),
            np.array([s.x for s in self.snapshots]).reshape(-1, 3),
            np.array([s.P for s in self.snapshots]).reshape(-1, 3, 3),
        )
