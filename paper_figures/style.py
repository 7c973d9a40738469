"""The one style of every report figure: Agg backend, sizes, fonts, colours, PNG + PDF output.

Colours are fixed per role: ground truth black, dead reckoning grey (dashed), other methods
from a colour-blind-safe cycle in a stable order (sorted names), so a method keeps its colour
across figures.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["plt", "apply", "save", "method_style", "TRUTH", "WIDTH"]

WIDTH = 6.4  # inches: one column of a report
TRUTH = {"color": "black", "linewidth": 1.2, "label": "ground truth"}
_CYCLE = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442"]

RC = {
    "figure.dpi": 150,
    "savefig.dpi": 150,
    "font.size": 9,
    "axes.titlesize": 9,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "lines.linewidth": 1.0,
}


def apply() -> None:
    plt.rcParams.update(RC)


def method_style(name: str, methods: list[str]) -> dict:
    """Line style of method ``name`` among ``methods`` (the estimator labels of the experiment)."""
    if name.startswith("dead_reckoning"):
        return {"color": "0.45", "linestyle": "--", "label": name}
    others = sorted(m for m in methods if not m.startswith("dead_reckoning"))
    return {"color": _CYCLE[others.index(name) % len(_CYCLE)] if name in others else _CYCLE[0], "linestyle": "-", "label": name}


def save(fig, directory: Path, stem: str) -> list[Path]:
    """Write ``<stem>.png`` and ``<stem>.pdf`` atomically; close the figure; return the paths."""
    import os

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in ("png", "pdf"):
        path = directory / f"{stem}.{ext}"
        tmp = directory / f".{stem}.{os.getpid()}.tmp.{ext}"
        fig.savefig(tmp, format=ext, bbox_inches="tight")
        os.replace(tmp, path)
        paths.append(path)
    plt.close(fig)
    return paths
