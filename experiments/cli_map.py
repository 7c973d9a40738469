"""``slamarena map LOG``: scan-matching grid SLAM over a laser log, with its outputs.

LOG is a registry name (``carmen:intel``, ``carmen-corrected:aces``, ``sim:laser``) or the path
of a CARMEN log (``.clf``/``.log``, optionally ``.gz``/``.bz2``). Writes into ``--out``:

    trajectory.tum      the estimated robot poses at the scan stamps (TUM, z = 0)
    estimate.npz        the full :class:`~slamarena.datasets.estimate.Estimate` (diagnostics included)
    map.png             the finest grid, 1 − p in grey (white free, black occupied)
    map.pgm, map.yaml   the same map for ROS map_server (trinary)
    summary.json        timing (total, per scan, real-time factor), counts of bad beams and
                        unmatched scans, map size, beam layouts (interlaced logs: one stream,
                        several angle offsets); the relation error when ``--relations`` is given
"""
from __future__ import annotations

import json
import time
from pathlib import Path

__all__ = ["map_command", "load_log"]


def load_log(log: str):
    """A registry name, or a path to a CARMEN log, as a Sequence."""
    from slamarena import datasets
    from slamarena.datasets.catalogue import CATALOGUE
    from slamarena.datasets.registry import SIMULATORS

    if log in SIMULATORS or log in CATALOGUE:
        return datasets.load(log)
    path = Path(log)
    if path.is_file():
        from slamarena.datasets.formats.carmen import read

        return read(path)
    raise FileNotFoundError(f"{log!r} is neither a dataset name (see `slamarena data list`) nor a file")


def map_command(log: str, matcher: str = "gauss_newton", out: Path = Path("results/maps"), relations: Path | None = None) -> int:
    from pydantic import ValidationError
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from slamarena.datasets.errors import DataFormatError, DatasetNotFoundError
    from slamarena.mapping.grid_slam import GridSLAM

    console = Console()
    try:
        slam = GridSLAM(matcher=matcher)
    except ValidationError as exc:
        console.print("[red]" + escape("; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors())) + "[/red]")
        return 2
    if relations is not None and not Path(relations).is_file():
        console.print(f"[red]relations file {relations} does not exist[/red]")
        return 2
    try:
        sequence = load_log(log)
    except (FileNotFoundError, DatasetNotFoundError, DataFormatError, KeyError, ValueError) as exc:
        console.print(f"[red]{exc}[/red]")
        return 1
    if getattr(sequence, "scans", None) is None or not len(sequence.scans):
        console.print(f"[red]{log}: no laser scans to map[/red]")
        return 1

    import numpy as np

    from slamarena.datasets.formats import tum

    K = len(sequence.scans)
    t0 = time.perf_counter()
    with Progress(TextColumn(f"mapping {log} ({matcher})"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(), console=console, transient=False) as bar:
        task = bar.add_task("scans", total=K)
        estimate = slam.run(sequence, progress=lambda k, _K: bar.update(task, completed=k) if k % 50 == 0 or k == _K else None)
    wall = time.perf_counter() - t0

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    tum.write(out / "trajectory.tum", estimate.t, estimate.poses)
    estimate.save(out / "estimate.npz")
    slam.map.save_png(out / "map.png")
    slam.map.save_map_server(out / "map")
    duration = float(sequence.scans.t[-1] - sequence.scans.t[0])
    summary = {
        "log": log, "matcher": matcher, "scans": K, "log_duration_s": duration, "wall_s": wall,
        "beam_layouts": 1 if sequence.scans.angle_offset is None else int(np.unique(sequence.scans.angle_offset).size),
        "scan_steps_s": float(estimate.step_time.sum()),
        "per_scan_ms": {"mean": 1e3 * float(np.mean(estimate.step_time)), "median": 1e3 * float(np.median(estimate.step_time)),
                        "max": 1e3 * float(np.max(estimate.step_time))},
        "real_time_factor": duration / float(estimate.step_time.sum()) if duration > 0 else None,
        **{k: v for k, v in estimate.meta.items() if k != "params"}, "params": estimate.meta["params"],
    }
    if relations is not None:
        from slamarena.experiments.metrics.reference import MetricUnavailable
        from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file

        try:
            summary["relations"], _ = relation_error_from_file(estimate, sequence, RelationsParams(file=relations))
        except (MetricUnavailable, DataFormatError, ValueError) as exc:
            console.print(f"[red]relations: {exc}[/red]")
            return 1
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))

    rtf = summary["real_time_factor"]
    console.print(f"{K} scans in {wall:.1f} s ({summary['per_scan_ms']['mean']:.2f} ms/scan"
                  + (f", {rtf:.1f}× faster than real time" if rtf else "") + f"); map {slam.map.shape[1]}×{slam.map.shape[0]} cells "
                  f"at {slam.map.params.resolution} m; bad beams {estimate.meta['bad_beams']}, scans not matched {estimate.meta['scans_not_matched']}")
    if "relations" in summary:
        r = summary["relations"]
        console.print(f"relations: {r['used']} used, {r['dropped']} dropped; translation {r['trans_mean']:.3f} ± {r['trans_std']:.3f} m, "
                      f"rotation {r['rot_mean']:.4f} ± {r['rot_std']:.4f} rad")
    console.print(f"wrote {out}/trajectory.tum, estimate.npz, map.png, map.pgm, map.yaml, summary.json")
    return 0
