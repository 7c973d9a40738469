"""An :class:`~slamarena.datasets.estimate.Estimate` and its method's occupancy grid, if any, as an MCAP file
(:func:`slamarena.datasets.formats.ros_results.write`): ``slamarena map … --mcap`` and a config's ``mcap: true``."""

from __future__ import annotations

from pathlib import Path

__all__ = ["write_result_mcap", "MCAP_NAME"]

MCAP_NAME = "result.mcap"


def write_result_mcap(path: str | Path, estimate, method=None) -> Path:
    """Write ``estimate`` (trajectory, landmarks where it has them) and ``method.map`` (an occupancy grid, where the
    method has one) to ``path``; returns the path. An existing file is replaced."""
    from slamarena.datasets.formats.ros_results import Grid, write

    grid_map = getattr(method, "map", None)
    grid = None
    if grid_map is not None and hasattr(grid_map, "to_ros"):
        grid = Grid(grid_map.to_ros(), grid_map.params.resolution, tuple(float(v) for v in grid_map.origin))
    landmarks = None
    if estimate.landmark_ids is not None and len(estimate.landmark_ids):
        landmarks = (estimate.landmark_ids, estimate.landmarks)
    path = Path(path)
    path.unlink(missing_ok=True)
    write(path, estimate.t, estimate.poses, grid=grid, landmarks=landmarks)
    return path
