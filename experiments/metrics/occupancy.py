"""Quality of the occupancy map a laser trajectory implies, without ground truth (:mod:`slamarena.mapping.evaluation`).

The dataset's scans are integrated into a log-odds grid (:class:`~slamarena.mapping.occupancy_grid.OccupancyGrid`,
its default cell model, cells of ``resolution``) at the estimate's poses — SE(2)-interpolated at the scan stamps;
scans outside the estimate's span are not used — every ``stride``-th scan. The grid is then scored:

* ``sharpness``, ``decided_fraction``: over the observed cells, the mean ``|2p − 1|`` and the fraction decided
  (free or occupied) (:func:`~slamarena.mapping.evaluation.map_sharpness`);
* ``hits``: the fraction of the integrated scans' usable end points within ``tol`` cells of an occupied cell
  (:func:`~slamarena.mapping.evaluation.hits_on_occupied`);
* ``wall_concentration``: how well the walls share two perpendicular directions, ``R = |Σ w e^{4iθ}| / Σ w``
  (:func:`~slamarena.mapping.evaluation.wall_orientation_concentration`; for rectilinear buildings).

A pose error blurs or doubles walls, which lowers ``hits`` and ``wall_concentration``; ``sharpness`` and
``decided_fraction`` are not a ranking by themselves (a 0.1 rad heading drift over a lap of ``sim:laser``'s ``rooms``
world raised both slightly), so only the first two are marked best in a table. They compare trajectories on one log,
not logs. Unavailable for a dataset without scans.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PositiveFloat, PositiveInt

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import interpolate_poses

from .reference import MetricUnavailable

__all__ = ["OccupancyParams", "occupancy_quality", "OCCUPANCY_OUTPUTS"]


class OccupancyParams(BaseModel):
    model_config = ConfigDict(extra="forbid")

    resolution: PositiveFloat = Field(0.05, description="cell side of the grid the scans are integrated into [m]")
    stride: PositiveInt = Field(1, description="integrate every stride-th scan [1]")
    tol: int = Field(1, ge=0, description="distance of an end point to an occupied cell that counts as a hit [cells]")
    sigma: PositiveFloat = Field(2.0, description="σ of the derivative-of-Gaussian wall gradient [cells]")


OCCUPANCY_OUTPUTS = {
    "sharpness": (None, "mean |2p − 1| over the observed cells of the map the trajectory implies"),
    "decided_fraction": (None, "fraction of the observed cells decided (free or occupied)"),
    "hits": ("higher", "fraction of the scans' end points within tol cells of an occupied cell"),
    "wall_concentration": ("higher", "R of the walls' directions (1: two perpendicular directions)"),
}


def occupancy_quality(estimate: Estimate, data, params: OccupancyParams = OccupancyParams()) -> tuple[dict, dict]:
    from slamarena.mapping.evaluation import hits_on_occupied, map_sharpness, wall_orientation_concentration
    from slamarena.mapping.occupancy_grid import OccupancyGrid

    scans = getattr(data, "scans", None)
    if scans is None or not len(scans):
        raise MetricUnavailable("the dataset has no scans")
    if len(estimate.t) < 2:
        raise MetricUnavailable("the estimate has fewer than two poses")
    index = np.arange(0, len(scans), params.stride)
    index = index[(scans.t[index] >= estimate.t[0]) & (scans.t[index] <= estimate.t[-1])]
    if not index.size:
        raise MetricUnavailable("no scan lies within the estimate's span")
    poses = interpolate_poses(estimate.t, estimate.poses, scans.t[index])
    grid = OccupancyGrid(resolution=params.resolution)
    for k, pose in zip(index.tolist(), poses):
        ranges, angles = scans.beams(k)
        grid.integrate(ranges, angles, pose, scans.mount, scans.max_range)
    sharp = map_sharpness(grid)
    return {
        "sharpness": sharp["sharpness"],
        "decided_fraction": sharp["decided_fraction"],
        "hits": hits_on_occupied(grid, scans, poses, index, tol=params.tol),
        "wall_concentration": wall_orientation_concentration(grid, sigma=params.sigma),
    }, {}
