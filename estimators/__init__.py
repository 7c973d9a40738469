"""Landmark and pose estimators behind one protocol: ``run(sequence) -> Estimate``.

``REGISTRY`` maps the name an experiment config uses to ``"module:Class"``; the class is
imported on first use (so heavy libraries such as GTSAM load only when a method needs them)
and constructed with the config's parameters.
"""

from __future__ import annotations

from slamarena.errors import UnknownNameError
from slamarena.targets import import_target

from .base import Estimate, Estimator

__all__ = ["REGISTRY", "REQUIRES", "create", "Estimate", "Estimator"]

REGISTRY: dict[str, str] = {
    "dead_reckoning": "slamarena.estimators.dead_reckoning:DeadReckoning",
    "ekf_slam": "slamarena.estimators.ekf_slam:EKFSLAM",
    "ekf_localizer": "slamarena.estimators.ekf_localizer:EKFLocalizer",
    "fastslam": "slamarena.estimators.fastslam:FastSLAM",
    "gtsam_batch": "slamarena.estimators.gtsam_smoother:BatchSmoother",
    "gtsam_isam2": "slamarena.estimators.gtsam_smoother:ISAM2Smoother",
    "gtsam_fixed_lag": "slamarena.estimators.gtsam_smoother:FixedLagLocalizer",
    "gtsam_pose_graph": "slamarena.estimators.gtsam_smoother:PoseGraphOptimizer",
    "stereo_vo": "slamarena.estimators.vision.estimators:StereoVO",
    "mono_vo": "slamarena.estimators.vision.estimators:MonoVO",
}

#: method → the input streams it needs (slamarena.datasets.streams): each entry is a set of alternatives, one of
#: which the dataset must provide; the experiment config refuses a method on a dataset without them
REQUIRES: dict[str, tuple[frozenset[str], ...]] = {
    "dead_reckoning": (frozenset({"motion"}),),
    "ekf_slam": (frozenset({"motion"}), frozenset({"range_bearing"})),
    "ekf_localizer": (frozenset({"motion"}),),
    "fastslam": (frozenset({"motion"}), frozenset({"range_bearing"})),
    "gtsam_batch": (frozenset({"motion"}), frozenset({"range_bearing", "beacon_ranges"})),
    "gtsam_isam2": (frozenset({"motion"}), frozenset({"range_bearing", "beacon_ranges"})),
    "gtsam_fixed_lag": (frozenset({"motion"}),),
    "gtsam_pose_graph": (frozenset({"graph", "range_bearing", "beacon_ranges"}),),
    "stereo_vo": (frozenset({"camera"}),),
    "mono_vo": (frozenset({"camera"}),),
}


def create(name: str, **params) -> Estimator:
    """Construct the registered method ``name`` with ``params``."""
    if name not in REGISTRY:
        raise UnknownNameError(f"unknown estimator {name!r}; known: {', '.join(sorted(REGISTRY))}")
    return import_target(REGISTRY[name])(**params)
