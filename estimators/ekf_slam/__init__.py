"""EKF-SLAM: :class:`EKFSLAM` (efficient, O(n²) per observation), the literal dense reference
(:mod:`.reference`, the test oracle) and data association (:mod:`.association`).

The model, state layout and equations are stated in :mod:`.filter`.
"""
from .checks import CovarianceError
from .filter import EKFSLAM

__all__ = ["EKFSLAM", "CovarianceError"]
