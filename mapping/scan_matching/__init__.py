"""2D scan matchers: registry and the common result type.

Every matcher is a class built from its parameter model (``Class.Params``, :mod:`slamarena.params`: a
model or keywords) with ``kind`` telling what it matches against and a ``match`` method:

    kind = "grid":   match(maps: MapPyramid, points (N, 2), guess (3,)) -> MatchResult
    kind = "points": match(reference (M, 2) world points, points (N, 2), guess (3,)) -> MatchResult

``takes_odometry``: whether ``match`` also takes ``odometry=True`` (the guess carries the odometry's motion) and then
keeps the directions the scan does not constrain at the guess (the Gauss-Newton matcher; :mod:`.gauss_newton`,
"Degeneracy").

``points`` are the scan end points in the robot frame; ``guess`` and the result are robot
poses in the map (world) frame. Heavy libraries (numba, scipy, open3d, kiss_icp) are
imported inside the matcher modules only.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slamarena.errors import UnknownNameError
from slamarena.targets import import_target

__all__ = ["MATCHERS", "MatchResult", "make_matcher", "matcher_class"]

MATCHERS: dict[str, str] = {
    "gauss_newton": "slamarena.mapping.scan_matching.gauss_newton:GaussNewtonMatcher",
    "correlative": "slamarena.mapping.scan_matching.correlative:CorrelativeMatcher",
    "branch_and_bound": "slamarena.mapping.scan_matching.correlative:BranchAndBoundMatcher",
    "kiss_icp": "slamarena.mapping.scan_matching.icp:KissICPMatcher",
    "open3d_icp": "slamarena.mapping.scan_matching.icp:Open3DICPMatcher",
    "point_to_line": "slamarena.mapping.scan_matching.point_to_line:PointToLineICPMatcher",
}


@dataclass
class MatchResult:
    """pose (3,), covariance (3, 3), a matcher-specific score (higher is better), iterations."""

    pose: np.ndarray
    cov: np.ndarray
    score: float
    iterations: int = 0
    info: dict = field(default_factory=dict)


def matcher_class(name: str) -> type:
    """The class of a registered matcher (``KeyError`` listing the names)."""
    if name not in MATCHERS:
        raise UnknownNameError(f"unknown matcher {name!r}; known: {', '.join(MATCHERS)}")
    return import_target(MATCHERS[name])


def make_matcher(name: str, **params):
    """Instantiate a registered matcher by name; its ``Params`` model validates ``params``."""
    return matcher_class(name)(**params)
