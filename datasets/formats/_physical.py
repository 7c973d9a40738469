"""Physical ranges of measured quantities, and the rows outside them, dropped and counted with their lines.

A number can parse as a valid float and still not be a measurement: an odometry speed of 1e300 m/s, a negative
range, a range far beyond what the sensor can return. Each reader states, once, the range [low, high] of every
quantity it reads (a :class:`Bound`, with its unit and the reason for its limits: the platform's and sensor's
specifications with a margin, research/method/data-validation.md); a row with a finite value outside is dropped,
its line listed in ``meta["dropped_lines"]["out_of_range"]`` (shown by ``slamarena data info``) and announced by
one :class:`~slamarena.datasets.errors.DataWarning` naming the file and its first lines (:func:`dropped_lines`).
Non-finite values are left to the stream's own count (``nonfinite_rows``) and the estimators' rejection.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import DataWarning

__all__ = ["Bound", "outside", "dropped_lines"]


@dataclass(frozen=True)
class Bound:
    """The physical range ``low ≤ value ≤ high`` of one quantity [unit], and why these limits."""

    low: float
    high: float
    unit: str
    why: str

    def outside(self, values: np.ndarray) -> np.ndarray:
        """The finite values outside [low, high] (a mask like ``values``)."""
        v = np.asarray(values, dtype=float)
        with np.errstate(invalid="ignore"):
            return np.isfinite(v) & ((v < self.low) | (v > self.high))

    def __str__(self) -> str:
        return f"[{self.low:g}, {self.high:g}] {self.unit}"


def outside(columns: dict[str, tuple[np.ndarray, Bound]]) -> tuple[np.ndarray, str]:
    """The rows (a mask) with a finite value outside its bound in any of ``columns`` (name → (values (N,), bound)),
    and the reason to print: the names and bounds of the columns that have such a value."""
    masks = {name: bound.outside(values) for name, (values, bound) in columns.items()}
    rows = np.logical_or.reduce(list(masks.values()))
    reason = ", ".join(f"{name} outside {columns[name][1]}" for name, m in masks.items() if m.any())
    return rows, reason


def dropped_lines(path: str, line_numbers: np.ndarray, reason: str, noun: str = "row") -> list[int]:
    """The sorted 1-based ``line_numbers`` of dropped rows (``noun``: what a line holds, for the message), announced by
    one warning naming the file and the first lines."""
    numbers = np.sort(np.asarray(line_numbers, dtype=np.int64)).tolist()
    if numbers:
        shown = ", ".join(map(str, numbers[:5])) + (", …" if len(numbers) > 5 else "")
        warnings.warn(
            f"{path}:{numbers[0]}: {len(numbers)} {noun}(s) dropped, {reason} "
            f"({'line' if len(numbers) == 1 else 'lines'} {shown}; all in meta['dropped_lines'])",
            DataWarning,
        )
    return numbers
