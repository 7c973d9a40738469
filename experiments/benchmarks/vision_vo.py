"""``slamarena bench vision-vo``: the VO pipelines on the staged KITTI 00 frames, accuracy and speed in one table.

Rows: stereo VO (ours), stereo VO + windowed BA over 5 keyframes (ours + GTSAM), stereo VO with OpenCV's geometry
alone (the baseline), each on frames 0–99 (every frame with a right image, 84 m); monocular VO (ours) and with
OpenCV's geometry on frames 0–199 (145 m). ``--quick``: the first 40 / 80 frames.

Metrics (:mod:`slamarena.experiments.metrics.trajectory3d`): ATE after SE(3) (stereo) or Sim(3) (mono) alignment
as % of the path length; KITTI's t_rel [%] and r_rel [deg/100 m] over segments of 10, 20, 40 and 80 m from every
frame (the devkit's 100–800 m do not fit in 84 m; monocular: at the Sim(3) alignment's scale); end-point drift
[% of the path]; and the same from frame 15 on (over frames 0–14 the ground truth keeps a constant 0.860 m per frame
while the images show the car accelerating from ≈ 0.68; the stereo depths are right there:
research/notebook/2026-11-28-vision-2.md). Speed: frames per CPU second (one process,
one BLAS/numba/OpenCV thread) and its ratio to KITTI's 10 Hz (> 1: faster than real time). With ``--out``, the
trajectories go to ``vision_vo_tracks.json`` (figures: ``python -m slamarena.paper_figures.vision OUT``). Parameters
are the pipelines' defaults: the stereo ones set before any scoring, three monocular ones changed after a failed first run
on frames 0–60 (:class:`~slamarena.estimators.vision.mono_vo.MonoVOParams`).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from slamarena.experiments.benchmarks import aim, measure_single_threaded, table, write_rows

#: the staged data it reads (``slamarena bench list``)
STAGED_DATA: dict[str, bool] = {"kitti:00": True}

__all__ = ["main", "measure"]

LENGTHS = (10.0, 20.0, 40.0, 80.0)


def _scores(poses: np.ndarray, truth: np.ndarray, align: str, lo: int = 0) -> dict:
    from slamarena.experiments.metrics.trajectory3d import ate_3d, end_point_drift, kitti_relative_error

    P, Q = poses[lo:].copy(), truth[lo:]
    ate = ate_3d(P, Q, align)
    P[:, :3, 3] *= ate["scale"]  # monocular: the relative errors of the trajectory at the Sim(3) scale
    relative = kitti_relative_error(P, Q, LENGTHS, step=1)
    suffix = "" if lo == 0 else f"_from_{lo}"
    out = {
        f"ate_percent{suffix}": ate["rmse_percent_of_path"],
        f"t_rel_percent{suffix}": relative["t_rel_percent"],
        f"r_rel_deg_per_100m{suffix}": relative["r_rel_deg_per_100m"],
    }
    if align == "se3":
        out[f"drift_percent{suffix}"] = end_point_drift(P, Q)["percent_of_path"]
    return out


def measure(quick: bool = False) -> dict:
    import cv2

    from slamarena.datasets import load
    from slamarena.estimators.vision.mono_vo import MonoVOParams, mono_vo
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_vo
    from slamarena.experiments.metrics.trajectory3d import path_length

    cv2.setNumThreads(1)
    camera = load("kitti:00").camera
    stereo, mono = camera.select(slice(0, 40 if quick else 100)), camera.select(slice(0, 80 if quick else 200))
    stereo_vo(camera.select(slice(0, 3)))  # untimed: numba compilation, OpenCV's first calls
    runs = [
        ("stereo VO (ours)", "se3", stereo, lambda c: stereo_vo(c)),
        ("stereo VO + window BA (ours, GTSAM)", "se3", stereo, lambda c: stereo_vo(c, StereoVOParams(window=5))),
        (
            "stereo VO (OpenCV geometry)",
            "se3",
            stereo,
            lambda c: stereo_vo(c, StereoVOParams(tracking={"geometry": "opencv"})),
        ),
        ("mono VO (ours)", "sim3", mono, lambda c: mono_vo(c)),
        (
            "mono VO (OpenCV geometry)",
            "sim3",
            mono,
            lambda c: mono_vo(c, MonoVOParams(tracking={"geometry": "opencv"})),
        ),
    ]
    rows, tracks = [], {}
    for name, align, cam, run in runs:
        result = run(cam)
        tracks[name] = {
            "align": align,
            "estimate": result.poses[:, :3, 3].tolist(),
            "truth": cam.ground_truth[:, :3, 3].tolist(),
            "inliers": result.inliers.tolist(),
            "keyframes": list(result.keyframes),
        }
        fps = len(cam) / float(result.cpu_time.sum())
        rows.append(
            {
                "pipeline": name,
                "frames": len(cam),
                "path_m": float(path_length(cam.ground_truth)[-1]),
                **_scores(result.poses, cam.ground_truth, align),
                **_scores(result.poses, cam.ground_truth, align, lo=15),
                "keyframes": len(result.keyframes),
                "lost": result.lost,
                "median_inliers": float(np.median(result.inliers[result.inliers >= 0])),
                "fps_cpu": fps,
                "real_time_ratio": fps / 10.0,
            }
        )
    return {"rows": rows, "tracks": tracks}


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    measured = measure_single_threaded("slamarena.experiments.benchmarks.vision_vo", quick=quick)
    rows = measured["rows"]
    columns = ["pipeline", "frames", "ate_percent", "t_rel_percent", "r_rel_deg_per_100m", "drift_percent",
               "t_rel_percent_from_15", "drift_percent_from_15", "lost", "fps_cpu", "real_time_ratio"]  # fmt: skip
    shown = table("VO on KITTI 00 (stereo: SE(3) alignment; mono: Sim(3))", columns)
    for row in rows:
        shown.add_row(*[f"{row[c]:.3g}" if isinstance(row.get(c), float) else str(row.get(c, "")) for c in columns])
    console = Console(width=240)
    console.print(shown)
    for row in rows:  # issue 32: real time for KITTI's 10 Hz on one core
        console.print(
            f"{row['pipeline']}: {row['real_time_ratio']:.3g}x real time {aim('>= 1x', row['real_time_ratio'] >= 1)}"
        )
    write_rows(rows, out, "vision_vo.csv")
    if out is not None:  # figures from it: python -m slamarena.paper_figures.vision OUT
        (Path(out) / "vision_vo_tracks.json").write_text(json.dumps(measured["tracks"]))
        print(f"wrote {Path(out) / 'vision_vo_tracks.json'}")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
