"""A grid-based Rao-Blackwellised particle filter for laser SLAM (GMapping: Grisetti, Stachniss & Burgard 2007).

The posterior over trajectories and maps factors as ``p(x_1:t, m | z_1:t, u_1:t) = p(m | x_1:t, z_1:t) · p(x_1:t | z_1:t, u_1:t)``:
particles sample trajectories, and each carries the map its trajectory implies (an occupancy grid, computed
exactly given the poses). Modules:

* :mod:`.tiled_grid` — every particle's map pyramid in copy-on-write tiles shared between particles;
* :mod:`.proposal` — the improved proposal: scan matching against each particle's own map, a Gaussian fitted
  around the match from K points, the weight from its normaliser;
* :mod:`.filter` — :class:`RBPF`, the filter over a laser log (registered as ``rbpf`` in ``slamarena.mapping.REGISTRY``).

research/method/rbpf.md has the derivation, the sharing design and the results.
"""

from __future__ import annotations

from .filter import RBPF, RBPFParams

__all__ = ["RBPF", "RBPFParams"]
