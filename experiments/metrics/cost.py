"""Cost of a cell: per-step time (wall, or CPU for a method with step_clock="cpu") and the peak memory of the cell's process.

* ``step_median``, ``step_p95``: median and 95th percentile of ``Estimate.step_time`` [s];
  ``step_total``: their sum (the estimator's own accounting).
* ``wall``: wall time of ``run(sequence)`` measured by the runner around the call [s].
* ``realtime``: the recording's duration (its first to its last stamp, ``Sequence.t1 − t0``) over ``wall``: how many
  times faster than real time the method ran (datasets without time, pose graphs, have none).
* ``peak_rss_mb``: the peak resident set of the cell's process, read when the cell finishes
  [MiB] — Linux ``VmHWM`` (``/proc/self/status``), elsewhere ``getrusage().ru_maxrss`` (see
  :func:`peak_rss_mb`). Every cell runs in a process of its own, so this is the peak of that cell:
  interpreter, imported libraries, the dataset and the estimator (native allocations of
  GTSAM/Open3D included, which tracemalloc would miss). Locally that process is forked from a
  worker that imported the libraries already (:mod:`slamarena.experiments.cell`): their pages count
  as far as the cell touches them, as in a fresh process that imports them.
"""

from __future__ import annotations

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.params import Params

__all__ = ["CostParams", "cost", "COST_OUTPUTS", "peak_rss_mb"]


class CostParams(Params):
    """The cost metric takes no parameters."""


COST_OUTPUTS = {
    "step_median": ("lower", "median time per step (wall, or CPU with step_clock='cpu') [s]"),
    "step_p95": ("lower", "95th percentile time per step (wall, or CPU with step_clock='cpu') [s]"),
    "step_total": ("lower", "sum of the per-step times (wall, or CPU with step_clock='cpu') [s]"),
    "wall": ("lower", "wall time of the estimator run [s]"),
    "realtime": ("higher", "recording duration / wall time (× faster than real time)"),
    "peak_rss_mb": ("lower", "peak resident memory of the cell's process [MiB]"),
    "steps": (None, "number of estimated poses"),
}


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far [MiB].

    Linux: ``VmHWM`` of ``/proc/self/status``, the high-water mark of this process's own
    address space. (``getrusage().ru_maxrss`` is not used there: Linux carries it across
    ``exec``, so a cell started from a 200 MB runner would report at least 200 MB.)
    Elsewhere: ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` (macOS bytes, others KiB).
    """
    import sys

    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 2**20 if sys.platform == "darwin" else rss / 2**10


def cost(
    estimate: Estimate,
    wall: float | None = None,
    peak_rss: float | None = None,
    params: CostParams = CostParams(),
    duration: float | None = None,
) -> tuple[dict, dict]:
    """The cost outputs; ``duration`` is the recording's span [s] (``None``: no ``realtime``)."""
    out: dict = {"steps": int(len(estimate.t))}
    if estimate.step_time is not None and len(estimate.step_time):
        st = np.asarray(estimate.step_time, dtype=float)
        out.update(step_median=float(np.median(st)), step_p95=float(np.percentile(st, 95)), step_total=float(st.sum()))
    if wall is not None:
        out["wall"] = float(wall)
        if duration is not None and duration > 0 and wall > 0:
            out["realtime"] = float(duration) / float(wall)
    if peak_rss is not None:
        out["peak_rss_mb"] = float(peak_rss)
    series = (
        {}
        if estimate.step_time is None
        else {"t": estimate.t, "step_time": np.asarray(estimate.step_time, dtype=float)}
    )
    return out, series
