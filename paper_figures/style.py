"""The one style of every figure: paper sizes, embedded fonts, a fixed colour per method, legends outside the data.

Sizes. A figure is drawn at its printed size, one column (``COLUMN`` = 3.5 in: IEEE's column is 3.5 in,
Springer's and Elsevier's 3.3–3.5 in) or the full text width of a two-column paper (``PAGE`` = 7.16 in), with
8 pt text, and saved without cropping (``bbox_inches="tight"`` would change the width), so it is placed at 100 %.
The layout is matplotlib's constrained layout, which keeps the labels and the legend inside that width.

Fonts. PDFs embed their fonts as TrueType (``pdf.fonttype`` 42): the default, Type 3, is rejected by journals'
PDF checks and does not render as text. PNGs (200 dpi) are for the HTML report.

Colours. :class:`MethodStyles` gives every method of a run one (colour, line style) pair, the same in every figure
of the run: ground truth black, dead reckoning grey dashed, the other methods in the order of the run's config
(``manifest.json``) through Paul Tol's "muted" scheme, nine colours that stay distinct under the common colour-vision
deficiencies (https://personal.sron.nl/~pault/); a tenth method and beyond reuse the colours with dashed, then
dotted lines, so no two methods share a pair. The pair is fixed by the run's whole method list, not by the methods a
figure happens to draw, so a method keeps its colour when another has no panel.

Legends. :func:`save` puts one legend for the whole figure below the axes (:func:`legend_outside`), never over
the data.

Axis limits. :func:`robust_limits` spans the 0.5–99.5 % quantiles of the values drawn (and what must stay visible,
such as a χ² band), so one outlier (a prior's NEES of 1e-20 at t = 0) does not stretch a log axis over 20 decades.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from slamarena.experiments.results import CAPTION_SUFFIX  # noqa: E402

__all__ = [
    "plt",
    "apply",
    "figure",
    "panel_grid",
    "figure_runs",
    "panels_used",
    "log_axis",
    "save",
    "legend_outside",
    "robust_limits",
    "MethodStyles",
    "TRUTH",
    "COLUMN",
    "PAGE",
]

COLUMN = 3.5  # inches: one column of a two-column paper
PAGE = 7.16  # inches: the text width of a two-column paper
TRUTH = {"color": "black", "linewidth": 1.0, "label": "ground truth"}
DEAD_RECKONING = {"color": "0.5", "linestyle": "--"}
#: Paul Tol's "muted" qualitative scheme (colour-blind safe), in his order
MUTED = ["#332288", "#CC6677", "#117733", "#88CCEE", "#882255", "#44AA99", "#DDCC77", "#AA4499", "#999933"]
LINESTYLES = ["-", "--", ":", "-."]

RC = {
    "figure.dpi": 100,
    "savefig.dpi": 200,
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "legend.fontsize": 7,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.5,
    "axes.linewidth": 0.6,
    "lines.linewidth": 0.8,
    "legend.frameon": False,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
}


def apply() -> None:
    plt.rcParams.update(RC)


def figure(width: float, height: float, nrows: int = 1, ncols: int = 1, **kwargs):
    """A figure of ``width`` × ``height`` inches (``COLUMN`` or ``PAGE`` wide) with constrained layout; (fig, axes 2-D)."""
    apply()
    return plt.subplots(nrows, ncols, figsize=(width, height), layout="constrained", squeeze=False, **kwargs)


def panel_grid(n: int, row_height: float, **kwargs):
    """A figure for ``n`` panels filled row by row: one column wide (``COLUMN``) for up to two, else two columns
    the page wide (``PAGE``); (fig, axes 2-D). Finish it with :func:`panels_used`."""
    ncols = 1 if n < 3 else 2
    nrows = -(-n // ncols)
    return figure(COLUMN if ncols == 1 else PAGE, row_height * nrows + 0.5, nrows=nrows, ncols=ncols, **kwargs)


def figure_runs(results_dir, keep, missing: str):
    """(the finished runs ``keep(run)`` accepts, the run's :class:`MethodStyles` over all its runs); ``FigureSkipped``
    with ``missing`` when no run is kept."""
    from .runs import FigureSkipped, load_runs

    every = load_runs(results_dir)
    runs = [r for r in every if keep(r)]
    if not runs:
        raise FigureSkipped(missing)
    return runs, MethodStyles.of(results_dir, every)


def panels_used(axes, n: int, xlabel: str) -> None:
    """A grid of panels filled row by row with ``n`` panels: hide the rest, and label the x axis of each column's
    lowest panel in use (the one above a hidden panel shows its tick labels)."""
    nrows, ncols = axes.shape
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.set_visible(False)
        elif k + ncols >= n:
            ax.set_xlabel(xlabel)
            ax.xaxis.set_tick_params(labelbottom=True)


def log_axis(ax, which: str = "y", limits: tuple[float, float] | None = None) -> None:
    """A log axis with plain-number labels at 1, 2 and 5 times the powers of ten (only the powers where the axis spans
    more than two decades) and no minor labels."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis = ax.yaxis if which == "y" else ax.xaxis
    (ax.set_yscale if which == "y" else ax.set_xscale)("log")
    if limits is not None:
        (ax.set_ylim if which == "y" else ax.set_xlim)(*limits)
    lo, hi = ax.get_ylim() if which == "y" else ax.get_xlim()
    axis.set_major_locator(LogLocator(subs=(1.0,) if np.log10(hi / lo) > 2 else (1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


class MethodStyles:
    """The line style of each method of a run: ``styles(label)`` → ``{"color", "linestyle", "label"}``.

    ``methods`` lists the run's methods as (label, method name) in the config's order; dead reckoning
    (method name ``dead_reckoning``) is grey dashed, the others take the palette in that order.
    """

    def __init__(self, methods: list[tuple[str, str]]):
        self._style: dict[str, dict] = {}
        others = 0
        for label, name in methods:
            if label in self._style:
                continue
            if name == "dead_reckoning":
                self._style[label] = dict(DEAD_RECKONING)
            else:
                self._style[label] = {
                    "color": MUTED[others % len(MUTED)],
                    "linestyle": LINESTYLES[(others // len(MUTED)) % len(LINESTYLES)],
                }
                others += 1

    @classmethod
    def of(cls, results_dir: str | Path, runs) -> MethodStyles:
        """The styles of a results directory: the methods of its ``manifest.json`` config in order, then any
        other method label of ``runs`` (sorted)."""
        from .runs import config_entries

        return cls(config_entries(results_dir, "estimators") + sorted({(r.estimator, r.method) for r in runs}))

    def labels(self) -> list[str]:
        """The run's method labels in their order (the order of legends and tables)."""
        return list(self._style)

    def __call__(self, label: str) -> dict:
        if label not in self._style:
            raise KeyError(f"method {label!r} is not a method of this run")
        return {**self._style[label], "label": label}


def legend_outside(fig, ncols: int | None = None) -> None:
    """One legend for the figure, below its axes: every labelled artist of every axes, each label once."""
    entries: dict[str, object] = {}
    for ax in fig.axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            if not label.startswith("_"):
                entries.setdefault(label, handle)
    if entries:
        n = ncols or max(1, min(len(entries), int(fig.get_figwidth() // 1.7)))
        fig.legend(list(entries.values()), list(entries), loc="outside lower center", ncols=n, handlelength=2.2)


def robust_limits(
    values, log: bool = False, include=(), quantiles=(0.5, 99.5), margin: float = 0.05
) -> tuple[float, float]:
    """Axis limits that span the ``quantiles`` of the finite ``values`` (positive ones on a log axis) and every
    value of ``include``, widened by ``margin`` of the span (in decades on a log axis)."""
    v = np.concatenate([np.ravel(np.asarray(x, dtype=float)) for x in values]) if len(values) else np.zeros(0)
    v = v[np.isfinite(v) & (v > 0)] if log else v[np.isfinite(v)]
    extra = np.asarray(include, dtype=float).ravel()
    if v.size:
        extra = np.concatenate([extra, np.percentile(v, quantiles)])
    if log:
        extra = np.log10(extra[extra > 0])
    if extra.size == 0:
        return (0.1, 10.0) if log else (0.0, 1.0)
    lo, hi = float(extra.min()), float(extra.max())
    pad = margin * (hi - lo) if hi > lo else (0.5 if log else max(abs(lo), 1.0) * 0.1)
    lo, hi = lo - pad, hi + pad
    return (10**lo, 10**hi) if log else (lo, hi)


def save(fig, directory: Path, stem: str, caption: str) -> list[Path]:
    """Put the figure's legend below its axes (:func:`legend_outside`), then write ``<stem>.png``, ``<stem>.pdf``
    and the caption (``<stem>.caption``, plain text, read by the report) atomically, at the figure's own size;
    close the figure; return the image paths."""
    legend_outside(fig)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for ext in ("png", "pdf"):
        path = directory / f"{stem}.{ext}"
        tmp = directory / f".{stem}.{os.getpid()}.tmp.{ext}"
        fig.savefig(tmp, format=ext)
        os.replace(tmp, path)
        paths.append(path)
    tmp = directory / f".{stem}.{os.getpid()}.tmp{CAPTION_SUFFIX}"
    tmp.write_text(caption.strip() + "\n", encoding="utf-8")
    os.replace(tmp, directory / f"{stem}{CAPTION_SUFFIX}")
    plt.close(fig)
    return paths
