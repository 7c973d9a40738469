"""Factor-graph baselines on GTSAM: landmark SLAM (batch, iSAM2), pose graphs, fixed-lag localization.

Importing this package imports GTSAM; the estimator registry imports it only when one of these
methods is used.

    BatchSmoother        gtsam_batch       landmark SLAM, whole graph, LM / Gauss-Newton / Dogleg
    ISAM2Smoother        gtsam_isam2       the same graph grown one pose per step with iSAM2
    FixedLagLocalizer    gtsam_fixed_lag   cmd_vel + GPS + IMU yaw, IncrementalFixedLagSmoother
    PoseGraphOptimizer   gtsam_pose_graph  g2o / TORO / iSAM pose graphs

The model, the noise mapping from the filters and the frame conventions are in the module
docstrings of :mod:`.landmark`, :mod:`.noise` and in ``research/graph_slam.md``.
"""
from .batch import BatchSmoother
from .fixed_lag import FixedLagLocalizer
from .isam2 import ISAM2Smoother
from .pose_graph import PoseGraphOptimizer

__all__ = ["BatchSmoother", "ISAM2Smoother", "FixedLagLocalizer", "PoseGraphOptimizer"]
