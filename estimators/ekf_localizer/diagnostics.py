"""What the EKF localizer records: NIS values, rejected input and divergence recoveries.

Every measurement that reaches the gate leaves one :class:`NIS` (its stamp, NIS = yᵀ S⁻¹ y and
whether it was applied); every refused input a count per sensor and reason — ``nonfinite`` (NaN/inf
value or stamp), ``gate``, ``too_old`` (older than the history), ``unknown_landmark`` /
``unknown_beacon`` (no such id in the map); motion input is counted under ``motion`` — and every
divergence recovery (P inflated after a gate lockout) a count per sensor.

A timed step's :class:`Diagnostics` stays with its snapshot in the lagged-data history
(:mod:`.history`) and is added to the final record when the snapshot leaves it; a replay discards
and redoes it, so the totals describe the input as finally processed.

Arrays of :meth:`Diagnostics.arrays` (``Estimate.diagnostics`` of ``EKFLocalizer.run``):
``nis_<sensor>``, ``nis_<sensor>_t``, ``nis_<sensor>_accepted`` and ``nis_dim_<sensor>`` for sensor in
gps, imu, landmark, beacon (in time order), ``rejected_<sensor>_<reason>`` and ``recoveries_<sensor>``
counts, and ``nis``, ``nis_dof``, ``nis_t``: all sensors merged in time order (the names
:mod:`slamarena.experiments.metrics` reads).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

__all__ = ["Diagnostics", "NIS", "SENSORS", "Sensor", "MOTION"]

#: the measurement sensors
Sensor = Literal["gps", "imu", "landmark", "beacon"]
#: each measurement sensor's dimension: the degrees of freedom of its NIS
SENSORS: dict[str, int] = {"gps": 2, "imu": 1, "landmark": 2, "beacon": 1}
#: what refused motion input is counted under
MOTION = "motion"


@dataclass(frozen=True, slots=True)
class NIS:
    """One measurement at the gate: stamp t [s], NIS = yᵀ S⁻¹ y, and whether it was applied."""

    t: float
    value: float
    accepted: bool


@dataclass
class Diagnostics:
    """NIS values per sensor, rejections per sensor and reason, recoveries per sensor."""

    nis: dict[str, list[NIS]] = field(default_factory=lambda: {s: [] for s in SENSORS})
    rejected: dict[str, dict[str, int]] = field(default_factory=lambda: {s: {} for s in (MOTION, *SENSORS)})
    recoveries: dict[str, int] = field(default_factory=lambda: dict.fromkeys(SENSORS, 0))

    def gated(self, sensor: str, t: float, nis: float, accepted: bool) -> None:
        self.nis[sensor].append(NIS(t, nis, accepted))

    def reject(self, sensor: str, reason: str, n: int = 1) -> None:
        counts = self.rejected[sensor]
        counts[reason] = counts.get(reason, 0) + n

    def recover(self, sensor: str) -> None:
        self.recoveries[sensor] += 1

    def __iadd__(self, other: Diagnostics) -> Diagnostics:
        for sensor, values in other.nis.items():
            self.nis[sensor].extend(values)
        for sensor, counts in other.rejected.items():
            for reason, n in counts.items():
                self.reject(sensor, reason, n)
        for sensor, n in other.recoveries.items():
            self.recoveries[sensor] += n
        return self

    @classmethod
    def total(cls, parts: Iterable[Diagnostics]) -> Diagnostics:
        """A new record holding everything ``parts`` hold, in their order."""
        out = cls()
        for part in parts:
            out += part
        return out

    def arrays(self) -> dict[str, np.ndarray]:
        """The record as the arrays of ``Estimate.diagnostics`` (module docstring)."""
        out: dict[str, np.ndarray] = {}
        for sensor, dim in SENSORS.items():
            values = sorted(self.nis[sensor], key=lambda n: n.t)
            out[f"nis_{sensor}_t"] = np.array([n.t for n in values], dtype=float)
            out[f"nis_{sensor}"] = np.array([n.value for n in values], dtype=float)
            out[f"nis_{sensor}_accepted"] = np.array([n.accepted for n in values], dtype=bool)
            out[f"nis_dim_{sensor}"] = np.array(dim)
        t_all = np.concatenate([out[f"nis_{s}_t"] for s in SENSORS])
        order = np.argsort(t_all, kind="stable")
        out["nis_t"] = t_all[order]
        out["nis"] = np.concatenate([out[f"nis_{s}"] for s in SENSORS])[order]
        out["nis_dof"] = np.concatenate([np.full(out[f"nis_{s}"].size, d) for s, d in SENSORS.items()])[order]
        for sensor, counts in self.rejected.items():
            for reason, n in counts.items():
                out[f"rejected_{sensor}_{reason}"] = np.array(n)
        for sensor, n in self.recoveries.items():
            out[f"recoveries_{sensor}"] = np.array(n)
        return out
