"""Figures of the VO pipelines on KITTI 00, from ``slamarena bench vision-vo --out DIR`` (``DIR/vision_vo_tracks.json``)
or from a config's runs (:func:`plot_runs`).

- ``vo_top_view``: the camera positions seen from above (x right, z forward: KITTI's camera axes, y down dropped),
  each estimate after its alignment (SE(3) stereo, Sim(3) mono, :func:`~slamarena.experiments.metrics.trajectory3d.
  align_umeyama`), with the ground truth; one panel for the stereo rows, one for the monocular rows.
- ``vo_error_over_distance``: the aligned position error [m] against the distance travelled along the ground truth.
- ``vo_tracked_features``: PnP inliers per frame (tracked map points), keyframes marked.

Run: ``python -m slamarena.paper_figures.vision DIR`` (writes PNG, PDF and captions into DIR). The same figures of
a config's run (one panel per dataset): the figure kind ``vo`` (:func:`plot_runs`, ``figures: [vo]`` in
``kitti_vo``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.trajectory3d import align_umeyama

from .runs import FigureSkipped, config_entries, load_manifest, load_runs
from .style import PAGE, figure, save

__all__ = ["plot", "plot_runs", "draw"]


def _aligned(track: dict) -> tuple[np.ndarray, np.ndarray]:
    p, q = np.asarray(track["estimate"]), np.asarray(track["truth"])
    s, R, t = align_umeyama(p, q, with_scale=track["align"] == "sim3")
    return s * p @ R.T + t, q


def plot(directory: Path) -> list[Path]:
    """The bench's figures (``DIR/vision_vo_tracks.json``): one panel for the stereo rows, one for the mono rows."""
    directory = Path(directory)
    tracks = json.loads((directory / "vision_vo_tracks.json").read_text())
    frames = {a: max(len(t["truth"]) for t in tracks.values() if t["align"] == a) for a in ("se3", "sim3")}
    groups = {
        f"stereo (frames 0–{frames['se3'] - 1}, SE(3))": [n for n, t in tracks.items() if t["align"] == "se3"],
        f"mono (frames 0–{frames['sim3'] - 1}, Sim(3))": [n for n, t in tracks.items() if t["align"] == "sim3"],
    }
    return draw(tracks, groups, directory)


def plot_runs(results_dir: Path, out: Path) -> list[Path]:
    """The figure kind ``vo`` of a config's run (``slamarena run kitti_vo``): one panel per dataset, every camera
    estimate of the first seed (``Estimate.poses_3d``) against the camera's ground truth at its frames, aligned by
    SE(3) (metric scale) or Sim(3) (``meta.scale`` unobservable)."""
    import slamarena
    from slamarena.experiments.metrics.trajectory3d import camera_reference

    every = load_runs(results_dir)
    runs = [r for r in every if r.seed == every[0].seed and r.estimate.poses_3d is not None]
    if not runs:
        raise FigureSkipped("no run holds a 3-D camera trajectory (Estimate.poses_3d)")
    specs = dict(config_entries(results_dir, "datasets"))
    params = {
        (d.get("label") or d["name"]): d.get("params", {})
        for d in load_manifest(results_dir).get("config", {}).get("datasets", [])
    }
    tracks, groups = {}, {}
    for run in runs:
        data = slamarena.load(specs.get(run.dataset, run.dataset), **params.get(run.dataset, {}))
        P, Q = camera_reference(run.estimate, data)
        name = f"{run.dataset}/{run.estimator}"
        diagnostics = run.estimate.diagnostics or {}
        tracks[name] = {
            "label": run.estimator,
            "estimate": P[:, :3, 3],
            "truth": Q[:, :3, 3],
            "align": "sim3" if run.estimate.meta.get("scale") == "unobservable" else "se3",
            "inliers": np.asarray(diagnostics.get("inliers", np.full(len(P), -1))),
            "keyframes": np.asarray(diagnostics.get("keyframes", []), int),
        }
        align = "Sim(3)" if tracks[name]["align"] == "sim3" else "SE(3)"
        groups.setdefault(f"{run.dataset} ({len(P)} frames, {align})", []).append(name)
    return draw(tracks, groups, Path(out))


def draw(tracks: dict, groups: dict[str, list[str]], directory: Path) -> list[Path]:
    """The three figures of ``tracks`` (name → estimate (K, 3), truth (K, 3) positions, align, inliers (K,),
    keyframes, an optional label), one panel per group (title → track names)."""
    labels = {name: track.get("label", name) for name, track in tracks.items()}
    colour = {label: f"C{k}" for k, label in enumerate(dict.fromkeys(labels.values()))}  # one per pipeline
    rows = -(-len(groups) // 2)
    paths = []

    def panels(height: float):
        fig, axes = figure(PAGE, height * rows, nrows=rows, ncols=2)
        for ax in axes.flat[len(groups) :]:
            ax.set_visible(False)
        return fig, zip(axes.flat, groups.items())

    fig, grid = panels(3.0)
    for ax, (title, names) in grid:
        truth = None
        for name in names:
            p, truth = _aligned(tracks[name])
            ax.plot(p[:, 0], p[:, 2], label=labels[name], lw=1, color=colour[labels[name]])
        ax.plot(truth[:, 0], truth[:, 2], "k-", lw=1.5, label="ground truth", zorder=1)  # under the estimates
        ax.set(title=title, xlabel="x [m]", ylabel="z [m]")
        ax.set_aspect("equal", adjustable="datalim")  # a straight drive keeps a readable panel width
    paths += save(fig, directory, "vo_top_view", "Camera positions from above, each estimate after its alignment.")

    fig, grid = panels(2.6)
    for ax, (title, names) in grid:
        for name in names:
            p, q = _aligned(tracks[name])
            distance = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
            ax.plot(distance, np.linalg.norm(p - q, axis=1), label=labels[name], lw=1, color=colour[labels[name]])
        ax.set(title=title, xlabel="distance travelled [m]", ylabel="position error [m]")
    paths += save(fig, directory, "vo_error_over_distance", "Aligned position error over the distance travelled.")

    fig, grid = panels(2.6)
    for ax, (title, names) in grid:
        for name in names:
            inliers = np.asarray(tracks[name]["inliers"], float)
            inliers[inliers < 0] = np.nan
            keyframes = np.asarray(tracks[name]["keyframes"], int)
            ax.plot(inliers, label=labels[name], lw=1, color=colour[labels[name]])
            ax.plot(keyframes, inliers[keyframes], "|", color=colour[labels[name]], ms=6)
        ax.set(title=title, xlabel="frame", ylabel="PnP inliers (tracked points)")
    paths += save(fig, directory, "vo_tracked_features", "PnP inliers per frame; ticks mark keyframes.")
    return paths


if __name__ == "__main__":
    for path in plot(Path(sys.argv[1])):
        print(f"wrote {path}")
