"""The per-step series a cell writes to ``series.npz``, named ``"<metric>/<series>"``.

Each metric returns its series as a dict (``ate`` → ``{"t": …, "position_error": …}``); the cell
process flattens them to these keys (:mod:`slamarena.experiments.cell`), and the runner's Monte Carlo
table and :mod:`slamarena.paper_figures` read them back by the same names.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Series", "series_key"]


def series_key(metric: str, name: str) -> str:
    """The ``series.npz`` key of a metric's series ``name``."""
    return f"{metric}/{name}"


class Series(StrEnum):
    ATE_T = "ate/t"  # stamps of the matched poses [s]
    ATE_POSITION_ERROR = "ate/position_error"  # ‖p̂ − p‖ after alignment [m]
    ATE_HEADING_ERROR = "ate/heading_error"  # |θ̂ − θ| after alignment [rad]
    ATE_ALIGNED_POSES = "ate/aligned_poses"  # the estimate in the reference frame (K, 3)
    NEES_T = "nees/t"  # stamps of the pose NEES [s]
    NEES = "nees/nees"  # pose NEES, 3 degrees of freedom
    NIS_T = "nis/t"  # stamps of the innovations [s]
    NIS = "nis/nis"  # NIS of each innovation
    NIS_DOF = "nis/dof"  # its degrees of freedom
    RELATIONS_T = "relations/t"  # first stamp t_i of each matched relation [s]
    RELATIONS_TRANS_ERROR = "relations/trans_error"  # ‖ε_ij.xy‖ of each matched relation [m]
    RELATIONS_ROT_ERROR = "relations/rot_error"  # |ε_ij.θ| of each matched relation [rad]
