"""Occupancy-grid mapping, ray tracing, 2D scan matching and laser SLAM.

``REGISTRY`` maps experiment-config names to ``"module:Class"`` (imported on first use);
each class implements ``run(sequence) -> Estimate`` like the estimators.
"""
from __future__ import annotations

REGISTRY: dict[str, str] = {
    "grid_slam": "slamarena.mapping.grid_slam:GridSLAM",
    "rbpf": "slamarena.mapping.rbpf.filter:RBPF",
}
