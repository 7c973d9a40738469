"""Figures of the VO pipelines on KITTI 00, from ``slamarena bench vision-vo --out DIR`` (``DIR/vision_vo_tracks.json``).

- ``vo_top_view``: the camera positions seen from above (x right, z forward: KITTI's camera axes, y down dropped),
  each estimate after its alignment (SE(3) stereo, Sim(3) mono, :func:`~slamarena.experiments.metrics.trajectory3d.
  align_umeyama`), with the ground truth; one panel for the stereo rows, one for the monocular rows.
- ``vo_error_over_distance``: the aligned position error [m] against the distance travelled along the ground truth.
- ``vo_tracked_features``: PnP inliers per frame (tracked map points), keyframes marked.

Run: ``python -m slamarena.paper_figures.vision DIR`` (writes PNG, PDF and captions into DIR).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.trajectory3d import align_umeyama

from .style import PAGE, figure, save

__all__ = ["plot"]


def _aligned(track: dict) -> tuple[np.ndarray, np.ndarray]:
    p, q = np.asarray(track["estimate"]), np.asarray(track["truth"])
    s, R, t = align_umeyama(p, q, with_scale=track["align"] == "sim3")
    return s * p @ R.T + t, q


def plot(directory: Path) -> list[Path]:
    directory = Path(directory)
    tracks = json.loads((directory / "vision_vo_tracks.json").read_text())
    frames = {a: max(len(t["truth"]) for t in tracks.values() if t["align"] == a) for a in ("se3", "sim3")}
    groups = {
        f"stereo (frames 0–{frames['se3'] - 1}, SE(3))": "se3",
        f"mono (frames 0–{frames['sim3'] - 1}, Sim(3))": "sim3",
    }
    colour = {name: f"C{k}" for k, name in enumerate(tracks)}  # one colour per pipeline in every panel
    paths = []

    fig, axes = figure(PAGE, 3.0, ncols=2)
    for ax, (title, align) in zip(axes[0], groups.items()):
        truth = None
        for name, track in tracks.items():
            if track["align"] == align:
                p, truth = _aligned(track)
                ax.plot(p[:, 0], p[:, 2], label=name, lw=1, color=colour[name])
        ax.plot(truth[:, 0], truth[:, 2], "k-", lw=1.5, label="ground truth" if align == "se3" else None)
        ax.set(title=title, xlabel="x [m]", ylabel="z [m]", aspect="equal")
    paths += save(fig, directory, "vo_top_view", "Camera positions from above, each estimate after its alignment.")

    fig, axes = figure(PAGE, 2.6, ncols=2)
    for ax, (title, align) in zip(axes[0], groups.items()):
        for name, track in tracks.items():
            if track["align"] == align:
                p, q = _aligned(track)
                distance = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
                ax.plot(distance, np.linalg.norm(p - q, axis=1), label=name, lw=1, color=colour[name])
        ax.set(title=title, xlabel="distance travelled [m]", ylabel="position error [m]")
    paths += save(fig, directory, "vo_error_over_distance", "Aligned position error over the distance travelled.")

    fig, axes = figure(PAGE, 2.6, ncols=2)
    for ax, (title, align) in zip(axes[0], groups.items()):
        for name, track in tracks.items():
            if track["align"] == align:
                inliers = np.asarray(track["inliers"], float)
                inliers[inliers < 0] = np.nan
                ax.plot(inliers, label=name, lw=1, color=colour[name])
                ax.plot(track["keyframes"], inliers[track["keyframes"]], "|", color=colour[name], ms=6)
        ax.set(title=title, xlabel="frame", ylabel="PnP inliers (tracked points)")
    paths += save(fig, directory, "vo_tracked_features", "PnP inliers per frame; ticks mark keyframes.")
    return paths


if __name__ == "__main__":
    for path in plot(Path(sys.argv[1])):
        print(f"wrote {path}")
