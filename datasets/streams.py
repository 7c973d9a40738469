"""Which input streams a dataset provides, known without loading it: the run-time inputs of a
:class:`~slamarena.datasets.sequence.Sequence` (``motion``, ``range_bearing``, ``beacon_ranges``, ``gps``,
``heading``, ``scans``, ``camera``) or ``graph`` for a :class:`~slamarena.datasets.posegraph.PoseGraph`.

A dataset's streams follow from its format (the catalogue entry's reader) or its simulator. The experiment config
checks them against what each method needs (``REQUIRES`` of the estimator and mapping registries) before any cell
runs. Ground truth is not a stream here: a method never needs it to run (metrics without it are skipped).
"""

from __future__ import annotations

from slamarena.errors import UserError

__all__ = ["STREAMS", "streams_of"]

#: reader or simulator target → the streams its datasets provide
STREAMS: dict[str, frozenset[str]] = {
    "slamarena.datasets.sim.landmarks:simulate": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.sim.localization:simulate": frozenset({"motion", "gps", "heading"}),
    "slamarena.datasets.sim.laser:simulate": frozenset({"motion", "scans"}),
    "slamarena.datasets.formats.mrclam:read": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.formats.victoria_park:load": frozenset({"motion", "range_bearing"}),
    "slamarena.datasets.formats.plaza:read": frozenset({"motion", "beacon_ranges"}),
    "slamarena.datasets.formats.carpark:read": frozenset({"motion", "scans"}),
    "slamarena.datasets.formats.carmen:load": frozenset({"motion", "scans"}),
    "slamarena.datasets.formats.kitti_odometry:read": frozenset({"camera"}),
    "slamarena.datasets.formats.vamr:read": frozenset({"camera"}),
    "slamarena.datasets.formats.g2o:load": frozenset({"graph"}),
    "slamarena.datasets.formats.toro:load": frozenset({"graph"}),
    "slamarena.datasets.formats.isam:load": frozenset({"graph"}),
}


#: the bag reader's streams follow from the bag's topic types (:func:`slamarena.datasets.formats.bag.streams_in`)
BAG_READER = "slamarena.datasets.formats.bag:load"


def streams_of(name: str, params: dict | None = None) -> frozenset[str]:
    """The streams of the dataset ``name`` (with ``params``, which locate a bag at a path): from its reader or
    simulator, or for a bag from its topics' types; empty when not known here (not described, or a bag absent)."""
    from .catalogue import CATALOGUE, FORMATS
    from .registry import SIMULATORS

    target = SIMULATORS.get(name) or (CATALOGUE[name].reader if name in CATALOGUE else None)
    family = name.partition(":")[0]
    if target == BAG_READER or (target is None and family in FORMATS and FORMATS[family].reader == BAG_READER):
        from .formats.bag import streams_in
        from .registry import resolve

        try:
            return streams_in(resolve(name, params).files()["bag"], params or {})
        except (UserError, ValueError, OSError):  # an absent or unreadable bag, bad options: the cell reports them
            return frozenset()
    return STREAMS.get(target, frozenset())
