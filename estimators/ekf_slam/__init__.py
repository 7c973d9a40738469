"""EKF-SLAM: :class:`EKFSLAM` (efficient, O(n²) per observation), the literal dense reference
(:mod:`.reference`, the test oracle) and data association (:mod:`.association`).

The model, state layout and equations are stated in :mod:`.filter`. ``EKFSLAM`` is imported on
first access, so importing this package does not load numba.
"""
from .checks import CovarianceError

__all__ = ["EKFSLAM", "CovarianceError"]


def __getattr__(name: str):
    if name == "EKFSLAM":
        from .filter import EKFSLAM

        return EKFSLAM
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
