"""Trajectory overlays: ground truth and every estimate of one seed per dataset, with the true landmarks and the
estimated ones with their 95 % covariance ellipses; an error-over-time panel where the estimates overlap.

Estimates are drawn after the ATE alignment of their cell (``series.npz`` ``ate/aligned_poses``
and ``metrics.json`` ``alignment``), so they sit in the ground-truth frame; the landmark
covariance is carried by the same similarity: ``Σ' = s² R Σ Rᵀ``. The 95 % ellipse of a 2D
Gaussian is ``{x : (x − m)ᵀ Σ⁻¹ (x − m) ≤ χ²₂(0.95) = 5.991}``.

Two curves cannot be told apart on the map when they lie closer than ``RESOLVABLE`` (1 %) of the plotted extent
— a line is ≈ 0.4 % of a column-wide panel. When two of the drawn curves (the ground truth included) stay that
close over half their length (:func:`overlapping`), a second panel shows each estimate's ATE position error over
time on a log axis, where the methods separate; the caption names the groups of curves that merge
(:func:`merged_groups`: the curves joined by a chain of such pairs), each curve once, not every pair.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.experiments.metrics.series import Series

from .runs import FigureSkipped, by, load_runs
from .style import COLUMN, TRUTH, MethodStyles, figure, log_axis, robust_limits, save

__all__ = ["plot", "ellipse_points", "overlapping", "merged_groups", "RESOLVABLE"]

CHI2_2_95 = 5.991464547107979
RESOLVABLE = 0.01  # fraction of the plotted extent below which two curves merge on the map


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
    A = run.alignment
    xy = A.points(est.landmarks)
    cov = None
    if est.landmark_cov is not None:
        c, s = np.cos(A.angle), np.sin(A.angle)
        R = np.array([[c, -s], [s, c]])
        cov = A.scale**2 * R @ est.landmark_cov @ R.T
    return xy, cov


def overlapping(
    curves: dict[str, tuple[np.ndarray, np.ndarray]], extent: float, resolvable: float = RESOLVABLE
) -> list[tuple[str, str]]:
    """Pairs of curves (name → (t, xy)) whose median distance, at the first one's stamps inside the second's
    span, is below ``resolvable · extent``: on the map they are one line."""
    pairs = []
    names = list(curves)
    for i, a in enumerate(names):
        ta, pa = curves[a]
        for b in names[i + 1 :]:
            tb, pb = curves[b]
            inside = (ta >= tb[0]) & (ta <= tb[-1])
            if inside.sum() < 2:
                continue
            other = np.column_stack([np.interp(ta[inside], tb, pb[:, k]) for k in (0, 1)])
            if np.median(np.linalg.norm(pa[inside] - other, axis=1)) < resolvable * extent:
                pairs.append((a, b))
    return pairs


def merged_groups(pairs: list[tuple[str, str]]) -> list[list[str]]:
    """The connected groups of the overlapping ``pairs`` (each curve once, in the order first named): the curves
    that form one line on the map."""
    group: dict[str, list[str]] = {}
    for a, b in pairs:
        ga, gb = group.setdefault(a, [a]), group.setdefault(b, [b])
        if ga is not gb:
            ga += gb
            for name in gb:
                group[name] = ga
    return list({id(g): g for g in group.values()}.values())


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs = load_runs(results_dir)
    styles = MethodStyles.of(results_dir, runs)
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        seed = min(r.seed for r in group)
        shown = [r for r in group if r.seed == seed]
        truth = next((r.truth for r in shown if "poses" in r.truth), None)
        curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        if truth is not None:
            curves[TRUTH["label"]] = (truth["t"], truth["poses"][:, :2])
        for run in shown:
            poses = run.series.get(Series.ATE_ALIGNED_POSES)
            if poses is None:
                poses = run.estimate.poses
            t = run.series.get(Series.ATE_T, run.estimate.t)
            curves[run.estimator] = (t, poses[:, :2])
        if not any(name != TRUTH["label"] for name in curves):
            continue
        xy = np.vstack([c[1] for c in curves.values()])
        extent = float(np.max(np.ptp(xy, axis=0)))
        merged = overlapping(curves, extent)
        with_errors = bool(merged) and any(Series.ATE_POSITION_ERROR in r.series for r in shown)
        fig, axes = figure(
            COLUMN,
            COLUMN * (1.25 if with_errors else 0.9) + 0.15 * (len(shown) + 2) / 2 + 0.3,
            nrows=2 if with_errors else 1,
            height_ratios=[2.6, 1] if with_errors else None,
        )
        ax = axes[0, 0]
        if truth is not None:
            ax.plot(truth["poses"][:, 0], truth["poses"][:, 1], **TRUTH)
            if "landmarks" in truth:
                ax.scatter(
                    truth["landmarks"][:, 0],
                    truth["landmarks"][:, 1],
                    marker="x",
                    s=12,
                    color="black",
                    linewidths=0.6,
                    label="true landmarks",
                    zorder=3,
                )
        ellipses = False
        for run in shown:
            style = styles(run.estimator)
            ax.plot(*curves[run.estimator][1].T, **style)
            lm, cov = _aligned_landmarks(run)
            if lm is not None:
                ax.scatter(lm[:, 0], lm[:, 1], s=6, color=style["color"], zorder=4)
                if cov is not None:
                    ellipses = True
                    for m, C in zip(lm, cov):
                        e = ellipse_points(m, C)
                        ax.plot(e[:, 0], e[:, 1], color=style["color"], linewidth=0.4)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        caption = (
            f"{dataset}, seed {seed}: ground truth (black) and each method's estimate after its ATE alignment "
            f"(estimates are in the ground-truth frame)"
            + (
                "; true landmarks ×, estimated landmarks • with their 95 % covariance ellipses (χ²₂(0.95) = 5.99)"
                if ellipses
                else ""
            )
            + "."
        )
        if with_errors:
            ax_e = axes[1, 0]
            values = []
            for run in shown:
                if Series.ATE_POSITION_ERROR in run.series:
                    e = run.series[Series.ATE_POSITION_ERROR]
                    ax_e.plot(run.series[Series.ATE_T], e, **styles(run.estimator))
                    values.append(e)
            log_axis(ax_e, "y", robust_limits(values, log=True))
            ax_e.set_xlabel("time [s]")
            ax_e.set_ylabel("position error [m]")
            groups = merged_groups(merged)
            caption += (
                " Lower panel: ATE position error over time (log scale), because "
                + ("these curves merge" if len(groups) == 1 else "each of these groups of curves merges")
                + f" into one line on the map (each curve within {RESOLVABLE:.0%} of the plot's extent of another of "
                + "its group): "
                + "; ".join(f"({', '.join(g)})" for g in groups)
                + "."
            )
        written += save(fig, out_dir, f"trajectories_{dataset}", caption)
    if not written:
        raise FigureSkipped("no trajectory to draw")
    return written
