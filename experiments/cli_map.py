"""``slamarena map LOG [--method M] [--param key=value …]``: a laser mapping method over a log, with its outputs.

LOG is a registry name (``carmen:intel``, ``carmen-corrected:aces``, ``bag:aces``, ``sim:laser``, a log at a path as
``carmen:<path>``, ``carmen-corrected:<path>`` or ``bag:<path>``), the path of a ROS bag (``.bag``, ``.mcap`` or a ROS 2
bag folder; short for ``bag:<path>``, which takes the one LaserScan and Odometry topic) or the path of a CARMEN log
(``.clf``/``.log``, optionally ``.gz``/``.bz2``; short for ``carmen:<path>``). M is a name of
``slamarena.mapping.REGISTRY`` (``grid_slam``, the front end alone, by default; ``laser_slam`` with loop closure;
``rbpf``), built with the ``--param`` values (its ``Params`` model validates them). Writes into ``--out``:

    trajectory.tum      the estimated robot poses at the log's own scan stamps (TUM, z = 0; results.write_trajectory_tum)
    estimate.npz        the full :class:`~slamarena.datasets.estimate.Estimate` (diagnostics included)
    map.png             the finest grid, 1 − p in grey (white free, black occupied)
    map.pgm, map.yaml   the same map for ROS map_server (trinary)
    pose_graph.g2o      the pose graph, for methods that build one (laser_slam)
    loop_closures.csv   every loop-closure candidate: node, submap, scores, accepted or the test that rejected it,
                        window, time (laser_slam)
    result.mcap         with ``--mcap``: /tf per pose, /trajectory (nav_msgs/Path), /map (nav_msgs/OccupancyGrid), for
                        Foxglove or RViz 2 (:mod:`slamarena.datasets.formats.ros_results`)
    summary.json        timing: wall, the one-off numba compilation apart (``compile_s``), per scan and the real-time
                        factor without it (``…_with_compilation``: with it), the method's counts, map size, beam layouts
                        (interlaced logs: one stream, several angle offsets); the relation error when
                        ``--relations`` is given
"""

from __future__ import annotations

import json
import time
from pathlib import Path

__all__ = ["map_command", "load_log", "parse_params", "write_loop_closures"]


def load_log(log: str):
    """A dataset name (``slamarena.datasets.load``: catalogued, ``carmen:<path>``, ``bag:<path>`` and the other family
    forms, a simulator), or the path of a ROS bag (``.bag``, ``.mcap``, a ROS 2 bag folder: short for ``bag:<path>``)
    or of a CARMEN log (short for ``carmen:<path>``), as a Sequence."""
    from slamarena import datasets
    from slamarena.errors import UnknownNameError, UserError

    try:
        return datasets.load(log)
    except UnknownNameError:
        if not Path(log).is_file():
            raise UserError(
                f"{log!r} is neither a dataset name (see `slamarena data list`, or <family>:<path> for a "
                f"recording at a path) nor a file"
            ) from None
    path = Path(log)
    ros = path.suffix in (".bag", ".mcap") or (path.is_dir() and (path / "metadata.yaml").is_file())
    return datasets.load(f"{'bag' if ros else 'carmen'}:{log}")


def parse_params(pairs: list[str]) -> dict:
    """``key=value`` pairs of ``--param`` into a nested dict; a dotted key names a parameter of a sub-model
    (``loop.level=2`` → ``{"loop": {"level": 2}}``, as ``slamarena params METHOD`` prints them); values are YAML
    (``0.05``, ``true``, ``[1, 2]``, ``cauchy``, ``{robust: huber}``)."""
    import yaml

    from slamarena.errors import UserError

    out: dict = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        *parents, name = [part.strip() for part in key.split(".")]
        if not sep or not all(parents) or not name:
            raise UserError(f"--param {pair!r}: write key=value (key: a name, or names joined by dots)")
        section = out
        for part in parents:
            section = section.setdefault(part, {})
            if not isinstance(section, dict):
                raise UserError(f"--param {pair!r}: {part} is given a value and a parameter inside it")
        if isinstance(section.get(name), dict):
            raise UserError(f"--param {pair!r}: {key.strip()} is given a value and a parameter inside it")
        section[name] = yaml.safe_load(value)
    return out


def map_command(
    log: str,
    method: str = "grid_slam",
    params: dict | None = None,
    out: Path = Path("results/maps"),
    relations: Path | None = None,
    mcap: bool = False,
) -> int:
    """Run a mapping method of ``slamarena.mapping.REGISTRY`` over a log and write its outputs (module docstring).
    User errors (a bad method, parameter, log or relations file) raise :class:`~slamarena.errors.UserError`."""
    from pydantic import ValidationError
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from slamarena.errors import UnknownNameError, UserError
    from slamarena.mapping import REGISTRY
    from slamarena.params import describe_error
    from slamarena.targets import import_target

    from .compilation import CompileClock

    console = Console()
    if method not in REGISTRY:
        raise UnknownNameError(f"unknown mapping method {method!r}; known: {', '.join(REGISTRY)}")
    try:
        slam = import_target(REGISTRY[method])(**(params or {}))
    except ValidationError as exc:
        raise UserError(f"{method}: " + "; ".join(describe_error(e) for e in exc.errors())) from None
    if relations is not None and not Path(relations).is_file():
        raise UserError(f"relations file {relations} does not exist")
    sequence = load_log(log)
    if getattr(sequence, "scans", None) is None or not len(sequence.scans):
        raise UserError(f"{log}: no laser scans to map")

    import numpy as np

    from slamarena.datasets.formats import g2o

    from .results import write_trajectory_tum

    K = len(sequence.scans)
    t0 = time.perf_counter()
    with Progress(
        TextColumn(f"mapping {log} ({method})"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=False,
    ) as bar:
        task = bar.add_task("scans", total=K)
        with CompileClock() as compilation:
            estimate = slam.run(
                sequence, progress=lambda k, _K: bar.update(task, completed=k) if k % 50 == 0 or k == _K else None
            )
    wall = time.perf_counter() - t0
    mapping = wall - compilation.seconds  # the one-off numba compilation (first run, cold cache) reported apart

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_trajectory_tum(out / "trajectory.tum", estimate.t, estimate.poses, sequence)
    estimate.save(out / "estimate.npz")
    slam.map.save_png(out / "map.png")
    slam.map.save_map_server(out / "map")
    written = ["trajectory.tum", "estimate.npz", "map.png", "map.pgm", "map.yaml"]
    if getattr(slam, "pose_graph", None) is not None:
        g2o.write(out / "pose_graph.g2o", slam.pose_graph)
        written.append("pose_graph.g2o")
    if "loop_node" in estimate.diagnostics:
        write_loop_closures(out / "loop_closures.csv", estimate.diagnostics)
        written.append("loop_closures.csv")
    if mcap:
        from .mcap_output import MCAP_NAME, write_result_mcap

        write_result_mcap(out / MCAP_NAME, estimate, slam)
        written.append(MCAP_NAME)
    duration = float(sequence.scans.t[-1] - sequence.scans.t[0])
    summary = {
        "log": log,
        "method": method,
        "scans": K,
        "log_duration_s": duration,
        "wall_s": wall,
        "compile_s": compilation.seconds,
        "beam_layouts": 1 if sequence.scans.angle_offset is None else int(np.unique(sequence.scans.angle_offset).size),
        "per_scan_ms": {
            "mean": 1e3 * mapping / K,
            "median": 1e3 * float(np.median(estimate.step_time)),
            "max": 1e3 * float(np.max(estimate.step_time)),
            "mean_with_compilation": 1e3 * wall / K,
        },
        "real_time_factor": duration / mapping if duration > 0 and mapping > 0 else None,
        "real_time_factor_with_compilation": duration / wall if duration > 0 and wall > 0 else None,
        **{k: v for k, v in estimate.meta.items() if k != "params"},
        "params": estimate.meta["params"],
    }
    if relations is not None:
        from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file

        summary["relations"], _ = relation_error_from_file(estimate, sequence, RelationsParams(file=relations))
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    written.append("summary.json")

    rtf = summary["real_time_factor"]
    extra = "; ".join(
        f"{k.replace('_', ' ')} {estimate.meta[k]}"
        for k in ("bad_beams", "scans_not_matched", "loop_closures", "resamplings")
        if k in estimate.meta
    )
    per_scan = summary["per_scan_ms"]
    compiled = (
        f"{compilation.seconds:.1f} s compiling numba kernels (once: they are cached for the next run), then "
        if compilation.seconds >= 0.05
        else ""
    )
    console.print(
        f"{K} scans in {wall:.1f} s ({compiled}{per_scan['mean']:.2f} ms/scan, median {per_scan['median']:.2f} ms"
        + (f", {rtf:.1f}× faster than real time" if rtf else "")
        + f"); map {slam.map.shape[1]}×{slam.map.shape[0]} cells at {slam.map.params.resolution} m"
        + (f"; {extra}" if extra else "")
    )
    if "loop_rejected_by" in estimate.meta:
        m = estimate.meta
        rejected = ", ".join(f"{n} by {t}" for t, n in m["loop_rejected_by"].items() if n) or "none"
        console.print(
            f"loop closures ({m['loop_verify']}): {m['loop_candidates']} candidates tried, {m['loop_closures']} accepted, "
            f"{m['loop_rejected']} rejected ({rejected})"
        )
    if "relations" in summary:
        r = summary["relations"]
        console.print(
            f"relations: {r['used']} used, {r['dropped']} dropped; translation {r['trans_mean']:.3f} ± {r['trans_std']:.3f} m, "
            f"rotation {r['rot_mean']:.4f} ± {r['rot_std']:.4f} rad"
        )
    console.print(f"wrote {out}/" + ", ".join(written))
    return 0


def write_loop_closures(path: Path, diagnostics: dict) -> None:
    """The loop-closure candidates as CSV: node, submap, anchor node, search and refined scores, accepted, the test
    that rejected it (empty when accepted), the search window's half-width [m], seconds, z."""
    d = diagnostics
    rows = ["node,submap,anchor,search_score,search_nodes,score,accepted,rejected_by,window,seconds,z_x,z_y,z_theta"]
    for k in range(d["loop_node"].size):
        z = d["loop_z"][k]
        rows.append(
            f"{d['loop_node'][k]},{d['loop_submap'][k]},{d['loop_anchor'][k]},{d['loop_search_score'][k]:.6g},{d['loop_search_nodes'][k]},"
            f"{d['loop_score'][k]:.6g},{int(d['loop_accepted'][k])},{d['loop_test'][k]},{d['loop_window'][k]:.4g},"
            f"{d['loop_seconds'][k]:.6g},{z[0]:.9g},{z[1]:.9g},{z[2]:.9g}"
        )
    Path(path).write_text("\n".join(rows) + "\n")
