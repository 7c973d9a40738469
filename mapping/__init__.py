"""Occupancy-grid mapping, ray tracing, 2D scan matching and laser SLAM.

``REGISTRY`` maps experiment-config names to ``"module:Class"`` (imported on first use);
each class implements ``run(sequence) -> Estimate`` like the estimators.
"""

from __future__ import annotations

REGISTRY: dict[str, str] = {
    "grid_slam": "slamarena.mapping.grid_slam:GridSLAM",
    "laser_slam": "slamarena.mapping.laser_slam:LaserSLAM",
    "rbpf": "slamarena.mapping.rbpf.filter:RBPF",
}

#: method → the input streams it needs (as ``slamarena.estimators.REQUIRES``)
REQUIRES: dict[str, tuple[frozenset[str], ...]] = {name: (frozenset({"scans"}),) for name in REGISTRY}
