"""slamarena's shared data layer: geometry, the data model, readers, simulators, the registry.

Depends on numpy, scipy (MAT files) and pydantic (the parameter models of readers and simulators,
through :mod:`slamarena.params`) besides the standard library; on gtsam, when installed, only to locate
the example data its wheel ships (:mod:`slamarena.datasets.dataroot`), on pooch only to download
(:mod:`slamarena.datasets.fetch`), and on rosbags only to read and write ROS bags and MCAP files
(:mod:`slamarena.datasets.formats.bag`, :mod:`slamarena.datasets.formats.ros_results`).
"""

from .dataroot import data_roots, set_data_root
from .errors import DataFormatError, DatasetNameError, DatasetNotFoundError, DataWarning
from .estimate import Estimate
from .posegraph import PoseGraph
from .registry import available, load
from .sequence import (
    BeaconRanges,
    Event,
    Gps,
    Heading,
    Increments,
    LandmarkMap,
    Noise,
    RangeBearing,
    Scans,
    Sequence,
    Trajectory,
    Twist,
)

__all__ = [
    "load",
    "available",
    "set_data_root",
    "data_roots",
    "DataFormatError",
    "DatasetNameError",
    "DatasetNotFoundError",
    "DataWarning",
    "Sequence",
    "PoseGraph",
    "Event",
    "Estimate",
    "Twist",
    "Increments",
    "RangeBearing",
    "BeaconRanges",
    "Gps",
    "Heading",
    "Scans",
    "Trajectory",
    "LandmarkMap",
    "Noise",
]
