"""notebook/2026-11-28-named-phases.md: the outputs of the three drivers split into named phases (issue 34), before
and after, compared array by array.

Run from the repository root::

    python research/scripts/named_phases_outputs.py dump before.pkl        # at the commit before the split
    python research/scripts/named_phases_outputs.py dump after.pkl         # at the commit after it
    python research/scripts/named_phases_outputs.py compare before.pkl after.pkl

``dump`` runs grid SLAM, laser graph SLAM (default; refinement off and two false loops) and the RBPF (10 particles)
on the first ``--scans`` scans of ``sim:laser`` (seed 0; laser SLAM also on all its scans, where the loop search finds
candidates), and the CARMEN reader on the five staged logs of
``radish_laser_logs`` (raw; fr-clinic also with
``interlaced=False``, Intel also with ``corrected=True`` to run that code path), and pickles every output as a flat
``{path: value}``: the estimates (poses, stamps, diagnostics, meta), the maps, the pose graph, every RBPF particle's
trajectory, the sequences' streams and meta. ``compare`` checks every array with ``np.array_equal`` (same dtype and
shape; NaN equal to NaN) and every other value with ``==``; the CPU / wall times (``step_time``, ``meta.seconds``,
``diagnostics.loop_seconds``)
are left out, as they differ from run to run.
"""

import argparse
import dataclasses
import pickle
import sys
import warnings
from pathlib import Path

import numpy as np

from slamarena import datasets
from slamarena.datasets.formats import carmen
from slamarena.mapping.grid_slam import GridSLAM
from slamarena.mapping.laser_slam.slam import LaserSLAM
from slamarena.mapping.rbpf.filter import RBPF

LOGS = Path("../shared/datasets/radish_laser_logs")
TIMES = {"step_time", "meta.seconds", "diagnostics.loop_seconds"}  # run-to-run CPU / wall times, not outputs


def flatten(value, prefix: str, out: dict) -> dict:
    """``value`` as ``{dotted path: leaf}``: dicts, lists, dataclasses and objects' attributes walked, arrays kept."""
    if isinstance(value, dict):
        for k, v in value.items():
            flatten(v, f"{prefix}.{k}", out)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            flatten(v, f"{prefix}[{i}]", out)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            flatten(getattr(value, f.name), f"{prefix}.{f.name}", out)
    elif isinstance(value, np.ndarray):
        out[prefix] = value.copy()
    elif isinstance(value, (int, float, str, bool, type(None), np.generic, Path)):
        out[prefix] = value
    else:
        for k, v in vars(value).items():
            if not k.startswith("_"):
                flatten(v, f"{prefix}.{k}", out)
    return out


def estimate(name: str, est, out: dict) -> None:
    """An Estimate's arrays, diagnostics and meta, the CPU times left out."""
    for key in ("t", "poses", "step_time", "diagnostics", "meta"):
        flatten(getattr(est, key), f"{name}.{key}", out)


def dump(path: str, scans: int) -> None:
    out: dict = {}
    seq = datasets.load("sim:laser", seed=0)
    seq = dataclasses.replace(seq, scans=seq.scans.select(slice(0, scans)))
    print(f"sim:laser seed 0: {len(seq.scans)} scans", flush=True)
    grid = GridSLAM()
    estimate("grid_slam", grid.run(seq), out)
    out["grid_slam.map"] = grid.map.log_odds.copy()
    for label, params in {
        "laser_slam": {},
        "laser_slam_norefine_false2": {"refine": {"neighbours": 0}, "loop": {"false_loops": 2}},
    }.items():
        slam = LaserSLAM(**params)
        estimate(label, slam.run(seq), out)
        out[f"{label}.map"] = slam.map.log_odds.copy()
        out[f"{label}.map_origin"] = slam.map.origin.copy()
        flatten(dataclasses.asdict(slam.pose_graph), f"{label}.pose_graph", out)
        print(label, "done", flush=True)
    full = datasets.load("sim:laser", seed=0)  # every scan: the loop closes, so the loop search runs
    slam = LaserSLAM()
    estimate("laser_slam_all_scans", slam.run(full), out)
    out["laser_slam_all_scans.map"] = slam.map.log_odds.copy()
    flatten(dataclasses.asdict(slam.pose_graph), "laser_slam_all_scans.pose_graph", out)
    print(f"laser_slam_all_scans ({len(full.scans)} scans) done", flush=True)
    rbpf = RBPF(particles=10)
    estimate("rbpf", rbpf.run(seq), out)
    out["rbpf.map"] = rbpf.map.log_odds.copy()
    out["rbpf.trajectories"] = np.stack([rbpf.trajectory(i) for i in range(10)])
    print("rbpf done", flush=True)
    logs = sorted(p for p in LOGS.glob("*.clf*"))
    runs = [(p, {}) for p in logs] + [
        (LOGS / "fr-clinic_robotlaser.clf.bz2", {"interlaced": False}),
        (LOGS / "intel.clf.bz2", {"corrected": True}),  # not a corrected log: the corrected code path, run
    ]
    for p, options in runs:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = carmen.read(p, **options)
        label = f"carmen.{p.name.split('.')[0]}" + "".join(f"_{k}={v}" for k, v in options.items())
        flatten(s, label, out)
        print(label, len(s.scans), "scans", flush=True)
    with open(path, "wb") as f:
        pickle.dump(out, f)
    print(f"{len(out)} values written to {path}")


def same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)) or a.dtype != b.dtype:
            return False
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    if isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b):
        return True
    return type(a) is type(b) and a == b


def compare(before: str, after: str) -> int:
    with open(before, "rb") as f:
        a = pickle.load(f)
    with open(after, "rb") as f:
        b = pickle.load(f)
    timing = lambda k: any(k.split(".", 1)[1].startswith(t) for t in TIMES) if "." in k else False
    keys = sorted(set(a) | set(b))
    skipped = [k for k in keys if timing(k)]
    checked = [k for k in keys if not timing(k)]
    differ = [k for k in checked if k not in a or k not in b or not same(a[k], b[k])]
    arrays = sum(isinstance(a.get(k), np.ndarray) for k in checked)
    groups = sorted({k.split(".")[0] if not k.startswith("carmen") else ".".join(k.split(".")[:2]) for k in keys})
    print(f"{len(checked)} values compared ({arrays} arrays by np.array_equal) in {', '.join(groups)}")
    print(f"{len(skipped)} timing values left out: {', '.join(skipped)}")
    print(f"{len(differ)} differ" + (": " + ", ".join(differ) if differ else ""))
    return 1 if differ else 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    d = sub.add_parser("dump")
    d.add_argument("out")
    d.add_argument("--scans", type=int, default=400)
    c = sub.add_parser("compare")
    c.add_argument("before")
    c.add_argument("after")
    args = ap.parse_args()
    if args.cmd == "dump":
        dump(args.out, args.scans)
    else:
        sys.exit(compare(args.before, args.after))


if __name__ == "__main__":
    main()
