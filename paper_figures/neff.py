"""Effective sample size over time of the particle filters, one panel per method that records it, per dataset.

A particle filter records ``N_eff = 1 / Σ w̃_i²`` after every update, before resampling, in its estimate's
diagnostics (``neff`` with its stamps ``neff_t``, and ``resampled``: whether that update resampled; FastSLAM,
:mod:`slamarena.estimators.fastslam.run`). It is drawn as the fraction ``N_eff / P`` of the P particles
(``meta["params"]["particles"]``), every seed a line, with the resampling threshold
(``meta["params"]["resample_threshold"]``, resample when ``N_eff < threshold · P``) dashed and the first seed's
resampling events as ticks along the bottom. A filter whose ``N_eff / P`` sits near 1/P carries one particle's
worth of information: its particle set has degenerated.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .runs import by
from .style import figure_runs, panel_grid, panels_used, save

__all__ = ["plot"]


def _has_neff(run) -> bool:
    return {"neff", "neff_t"} <= set(run.estimate.diagnostics)


def plot(results_dir: str | Path, out_dir: str | Path) -> list[Path]:
    runs, styles = figure_runs(
        results_dir, _has_neff, "no method records N_eff (diagnostics neff, neff_t: a particle filter)"
    )
    written = []
    for (dataset,), group in by(runs, "dataset").items():
        methods = by(group, "estimator")
        fig, axes = panel_grid(len(methods), 1.3, sharex=True)
        notes = []
        for ax, ((estimator,), seeds) in zip(axes.flat, methods.items()):
            style = styles(estimator)
            params = seeds[0].estimate.meta.get("params", {})
            P = params.get("particles")
            for k, run in enumerate(seeds):
                d = run.estimate.diagnostics
                ax.plot(
                    d["neff_t"],
                    d["neff"] / (P or 1),
                    color=style["color"],
                    linewidth=0.8 if k == 0 else 0.5,
                    alpha=1.0 if k == 0 else 0.4,
                    label=estimator if k == 0 else None,
                )
            first = seeds[0].estimate.diagnostics
            if "resampled" in first:
                ax.plot(
                    first["neff_t"][first["resampled"]],
                    np.zeros(int(first["resampled"].sum())),
                    linestyle="none",
                    marker="|",
                    markersize=5,
                    color="0.3",
                    label="resampling (first seed)",
                )
            if P and "resample_threshold" in params:
                ax.axhline(
                    params["resample_threshold"],
                    color="black",
                    linestyle="--",
                    linewidth=0.6,
                    label="resampling threshold",
                )
            ax.set_title(
                f"{estimator}: P = {P}, {len(seeds)} seed{'s' * (len(seeds) > 1)}"
                if P
                else f"{estimator}: {len(seeds)} seed{'s' * (len(seeds) > 1)}"
            )
            ax.set_ylabel("N_eff / P" if P else "N_eff")
            if P:
                ax.set_ylim(-0.05, 1.05)
            notes.append(
                f"{estimator} resampled at {int(first['resampled'].sum())} of {first['neff'].size} updates"
                if "resampled" in first
                else estimator
            )
        panels_used(axes, len(methods), "time [s]")
        caption = (
            f"{dataset}: effective sample size N_eff = 1 / Σ w̃² after every update (before resampling) as a fraction of the "
            f"particles, one panel per particle filter, every seed a line (the first drawn bold), the resampling threshold "
            f"dashed, the first seed's resampling events as ticks at the bottom ({'; '.join(notes)})."
        )
        written += save(fig, out_dir, f"neff_{dataset}", caption)
    return written
