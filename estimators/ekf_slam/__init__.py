"""EKF-SLAM: :class:`EKFSLAM` (efficient, O(n²) per observation; parameters :class:`EKFSLAMParams`), the literal dense reference
(:mod:`.reference`, the test oracle) and data association (:mod:`.association`).

The model, state layout and equations are stated in :mod:`.filter`. ``EKFSLAM`` is imported on
first access (with ``EKFSLAMParams``), so importing this package does not load numba.
"""

from .checks import CovarianceError

__all__ = ["EKFSLAM", "EKFSLAMParams", "CovarianceError"]


def __getattr__(name: str):
    if name in ("EKFSLAM", "EKFSLAMParams"):
        from . import filter as module
        from .run import run_sequence

        module.EKFSLAM.run = (
            run_sequence  # bound here, so that filter.py does not import its runner (run.py imports it)
        )
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
