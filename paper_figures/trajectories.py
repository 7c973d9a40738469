"""Trajectory overlays: ground truth, dead reckoning and every estimate of one seed per dataset,
with the true landmarks and the estimated ones with their 95 % covariance ellipses.

Estimates are drawn after the ATE alignment of their cell (``series.npz`` ``ate/aligned_poses``
and ``metrics.json`` ``alignment``), so they sit in the ground-truth frame; the landmark
covariance is carried by the same similarity: ``Σ' = s² R Σ Rᵀ``. The 95 % ellipse of a 2D
Gaussian is ``{x : (x − m)ᵀ Σ⁻¹ (x − m) ≤ χ²₂(0.95) = 5.991}``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.series import Series

from .runs import FigureSkipped, by, load_runs
from .style import TRUTH, WIDTH, apply, method_style, plt, save

__all__ = ["plot", "ellipse_points"]

CHI2_2_95 = 5.991464547107979


def ellipse_points(mean: np.ndarray, cov: np.ndarray, scale2: float = CHI2_2_95, n: int = 48) -> np.ndarray:
    """Boundary (n, 2) of ``(x − m)ᵀ Σ⁻¹ (x − m) = scale2``: ``m + sqrt(scale2) L [cos, sin]`` with Σ = L Lᵀ."""
    w, V = np.linalg.eigh(cov)
    L = V * np.sqrt(np.maximum(w, 0.0))
    a = np.linspace(0, 2 * np.pi, n)
    return mean + np.sqrt(scale2) * (np.column_stack([np.cos(a), np.sin(a)]) @ L.T)


def _aligned_landmarks(run):
    est = run.estimate
    if est.landmarks is None or len(est.landmarks) == 0:
        return None, None
    from slamarena.experiments.metrics.alignment import Alignment

    a = run.info.get("alignment") or {}
    A = Alignment(a.get("angle", 0.0), (a.get("tx", 0.0), a.get("ty", 0.0)), a.get("scale", 1.0))
    xy = A.points(est.landmarks)
    cov = None
    if est.landmark_cov is not None:
        c, s = np.cos(A.angle), np.sin(A.angle)
        R = np.array([[c, -s], [s, c]])
        cov = A.scale**2 * R @ est.landmark_cov @ R.T
    return xy, cov


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs = load_runs(results_dir)
    apply()
    methods = sorted({r.estimator for r in runs})
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        seed = min(r.seed for r in group)
        shown = [r for r in group if r.seed == seed]
        truth = next((r.truth for r in shown if "poses" in r.truth), None)
        fig, ax = plt.subplots(figsize=(WIDTH, WIDTH * 0.8))
        if truth is not None:
            ax.plot(truth["poses"][:, 0], truth["poses"][:, 1], **TRUTH)
            if "landmarks" in truth:
                ax.scatter(truth["landmarks"][:, 0], truth["landmarks"][:, 1], marker="x", s=18, color="black", linewidths=0.8, label="true landmarks", zorder=3)
        for run in shown:
            poses = run.series.get(Series.ATE_ALIGNED_POSES)
            if poses is None:
                poses = run.estimate.poses
            style = method_style(run.estimator, methods)
            ax.plot(poses[:, 0], poses[:, 1], **style)
            xy, cov = _aligned_landmarks(run)
            if xy is not None:
                ax.scatter(xy[:, 0], xy[:, 1], s=10, color=style["color"], zorder=4)
                if cov is not None:
                    for m, C in zip(xy, cov):
                        e = ellipse_points(m, C)
                        ax.plot(e[:, 0], e[:, 1], color=style["color"], linewidth=0.6)
        if not ax.lines:
            plt.close(fig)
            continue
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ellipses = "; landmark ellipses 95 %" if any(r.estimate.landmark_cov is not None for r in shown) else ""
        ax.set_title(f"{dataset} (seed {seed}; estimates aligned as for the ATE{ellipses})")
        ax.legend(loc="best")
        written += save(fig, out_dir, f"trajectories_{dataset}")
    if not written:
        raise FigureSkipped("no trajectory to draw")
    return written
