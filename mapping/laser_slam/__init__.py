"""Laser graph SLAM: the scan-to-submap front end and loop closure (:mod:`.slam`, :mod:`.loop_closure`) on a
GTSAM pose graph (:mod:`.backend`)."""

from .backend import OptimizationError
from .slam import LaserSLAM, LaserSLAMParams

__all__ = ["LaserSLAM", "LaserSLAMParams", "OptimizationError"]
