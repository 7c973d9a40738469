"""Factor-graph baselines on GTSAM: landmark SLAM (batch, iSAM2), pose graphs, fixed-lag localization.

Importing this package imports GTSAM; the estimator registry imports it only when one of these
methods is used.

    BatchSmoother        gtsam_batch       landmark SLAM, whole graph, LM / Gauss-Newton / Dogleg
    ISAM2Smoother        gtsam_isam2       the same graph grown one pose per step with iSAM2
    FixedLagLocalizer    gtsam_fixed_lag   cmd_vel + GPS + IMU yaw, IncrementalFixedLagSmoother
    PoseGraphOptimizer   gtsam_pose_graph  g2o / TORO / iSAM pose graphs

Each class declares its parameters as ``<Class>Params`` (``Class.Params``); the settings they share are
one model each, which the classes' models extend: :class:`~.problem.PoseChainParams` (motion model and
noise, start prior; batch, iSAM2, fixed lag), :class:`~.landmark.LandmarkSmootherParams` (extra pose keys,
odometry, observation and beacon noise, beacon anchors, marginals; batch, iSAM2), :class:`~.graph.RobustKernelParams` (all four),
:class:`~.graph.OptimizerParams` (batch, pose graph) and :class:`~.graph.RelinearizationParams` (iSAM2,
fixed lag).

Bad measurements are rejected and counted before they reach a graph (:mod:`.problem`); an optimisation
that reaches no optimum raises :class:`OptimizationError` (:mod:`.graph`), never returns a guess.

The model, the noise mapping from the filters and the frame conventions are in the module
docstrings of :mod:`.landmark`, :mod:`.noise` and in ``research/method/graph_slam.md``.
"""

from .batch import BatchSmoother, BatchSmootherParams
from .fixed_lag import FixedLagLocalizer, FixedLagLocalizerParams
from .graph import OptimizationError
from .isam2 import ISAM2Smoother, ISAM2SmootherParams
from .pose_graph import PoseGraphOptimizer, PoseGraphOptimizerParams

__all__ = [
    "BatchSmoother",
    "BatchSmootherParams",
    "ISAM2Smoother",
    "ISAM2SmootherParams",
    "FixedLagLocalizer",
    "FixedLagLocalizerParams",
    "PoseGraphOptimizer",
    "PoseGraphOptimizerParams",
    "OptimizationError",
]
