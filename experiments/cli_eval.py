"""``slamarena eval TRAJ --ref DATASET_OR_FILE``: score a trajectory from any system with the metrics registry.

TRAJ is a trajectory file (:mod:`slamarena.datasets.formats.trajectories`: TUM, KITTI poses, EuRoC CSV, g2o
vertices; by suffix or ``--format``; ``--kitti-frame camera`` for KITTI odometry ground truth, ``--max-tilt`` for
poses slightly out of the x-y plane). The reference is a trajectory file in one of those formats (``--ref-format``)
or a dataset name (``slamarena data list``, ``bag:<path>``, …; ``--ref-param key=value`` gives its reader's
options, such as a bag's ``truth_topic``): its ground truth, and for ``relations`` its relations file. Metrics are
names of :data:`slamarena.experiments.metrics.METRICS` with the parameters a config gives them: ``--align`` and
``--max-gap`` for ``ate`` (and ``max_gap`` for ``rpe``), ``--rpe-delta``/``--rpe-unit`` for ``rpe``. A metric that
does not apply (a file reference has no relations) is listed with the reason. TRAJ's stamps that are a log's own scan
stamps (as ``trajectory.tum`` carries them where the reader adjusted some) are read as the scans' times.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["evaluate_file", "eval_command"]


def _reference(ref: str, ref_format: str | None, ref_params: dict, kitti_frame: str, max_tilt: float):
    """(data the metrics may read, Reference) of a trajectory file or a dataset name."""
    from slamarena.datasets.formats import trajectories
    from slamarena.experiments.metrics.reference import Reference, reference_of

    path = Path(ref)
    if path.is_file() and (ref_format or path.suffix in (".tum", ".kitti", ".csv", ".g2o", ".txt")):
        truth = trajectories.read(path, ref_format, kitti_frame=kitti_frame, max_tilt=max_tilt)
        return None, Reference(truth.t, truth.poses, None, None, None)
    from slamarena import datasets

    data = datasets.load(ref, **ref_params)
    return data, reference_of(data)


def evaluate_file(
    traj: Path,
    ref: str,
    metrics: list[str],
    params: dict[str, dict],
    traj_format: str | None = None,
    ref_format: str | None = None,
    times: Path | None = None,
    ref_params: dict | None = None,
    kitti_frame: str = "xy",
    max_tilt: float = 1e-6,
) -> dict:
    """Scalars, skipped reasons and the counts of one trajectory file against a reference (module docstring)."""
    import numpy as np

    from slamarena.datasets.estimate import Estimate
    from slamarena.datasets.formats import trajectories
    from slamarena.datasets.log_stamps import sequence_times
    from slamarena.errors import UnknownNameError, UserError
    from slamarena.experiments.metrics import METRICS, CellData, evaluate

    unknown = [m for m in metrics if m not in METRICS]
    if unknown:
        raise UnknownNameError(f"unknown metric {', '.join(unknown)}; known: {', '.join(METRICS)}")
    try:
        selected = {m: METRICS[m].params(**params.get(m, {})) for m in metrics}
    except ValueError as exc:
        raise UserError(f"metric parameters: {exc}") from None
    for option, value, known in (
        ("--format", traj_format, trajectories.FORMATS),
        ("--ref-format", ref_format, trajectories.FORMATS),
        ("--kitti-frame", kitti_frame, ("xy", "camera")),
    ):
        if value is not None and value not in known:
            raise UserError(f"{option} {value!r}: one of {', '.join(known)}")
    estimated = trajectories.read(traj, traj_format, times, kitti_frame=kitti_frame, max_tilt=max_tilt)
    data, reference = _reference(ref, ref_format, ref_params or {}, kitti_frame, max_tilt)
    t, poses = estimated.t, estimated.poses
    if data is not None:  # a file at the log's own stamps (as trajectory.tum): the Sequence's times, in their order
        t = np.where(np.isnan(back := sequence_times(data, t, 0.0)), t, back)
        order = np.argsort(t, kind="stable")
        t, poses = t[order], poses[order]
    estimate = Estimate(method=Path(traj).name, t=t, poses=poses)
    scalars, _, skipped = evaluate(CellData(estimate, data, reference), selected)
    return {"trajectory": str(traj), "reference": ref, "poses": len(estimated), "metrics": scalars, "skipped": skipped}


def eval_command(result: dict, as_json: bool) -> int:
    """Print ``result`` of :func:`evaluate_file` as a table (or JSON); 0."""
    import json

    from rich.console import Console
    from rich.table import Table

    console = Console()
    if as_json:
        console.print_json(json.dumps(result, default=float))
        return 0
    table = Table(title=f"{result['trajectory']} ({result['poses']} poses) against {result['reference']}")
    for column in ("metric", "output", "value"):
        table.add_column(column)
    for metric, values in result["metrics"].items():
        for key, value in values.items():
            table.add_row(metric, key, f"{value:.6g}" if isinstance(value, float) else str(value))
    for metric, reason in result["skipped"].items():
        table.add_row(metric, "[dim]skipped[/dim]", reason)
    console.print(table)
    return 0
