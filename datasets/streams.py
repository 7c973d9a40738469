"""Which input streams a dataset provides, known without loading it: the run-time inputs of a
:class:`~slamarena.datasets.sequence.Sequence` (``motion``, ``range_bearing``, ``beacon_ranges``, ``gps``,
``heading``, ``scans``, ``camera``) or ``graph`` for a :class:`~slamarena.datasets.posegraph.PoseGraph`.

A dataset's streams follow from its format (the catalogue entry's reader) or its simulator. The experiment config
checks them against what each method needs (``REQUIRES`` of the estimator and mapping registries) before any cell
runs. Ground truth is not a stream here: a method never needs it to run (metrics without it are skipped).
"""

from __future__ import annotations

__all__ = ["STREAMS", "streams_of"]

#: reader or simulator target → the streams its datasets provide
STREAMS: dict[str, frozenset[str]] = {
    "slamarena.datasets.sim.landmarks:simulate": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.sim.localization:simulate": frozenset({"motion", "gps", "heading"}),
    "slamarena.datasets.sim.laser:simulate": frozenset({"motion", "scans"}),
    "slamarena.datasets.formats.mrclam:read": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.formats.victoria_park:load": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.formats.plaza:read": frozenset({"motion", "beacon_ranges"}),
    "slamarena.datasets.formats.carmen:load": frozenset({"motion", "scans"}),
    "slamarena.datasets.formats.kitti_odometry:read": frozenset({"camera"}),
    "slamarena.datasets.formats.vamr:read": frozenset({"camera"}),
    "slamarena.datasets.formats.g2o:load": frozenset({"graph"}),
    "slamarena.datasets.formats.toro:load": frozenset({"graph"}),
    "slamarena.datasets.formats.isam:load": frozenset({"graph"}),
}


def streams_of(name: str) -> frozenset[str]:
    """The streams of the registered dataset ``name`` (empty when its reader is not described here)."""
    from .catalogue import CATALOGUE
    from .registry import SIMULATORS

    target = SIMULATORS.get(name) or (CATALOGUE[name].reader if name in CATALOGUE else None)
    return STREAMS.get(target, frozenset())
