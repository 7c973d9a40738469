"""Regenerate every figure of a results directory: ``slamarena figures RESULTS_DIR``.

``FIGURES`` maps the figure kinds an experiment config may list (``slamarena.experiments.config.FIGURES``)
to the module function that draws them; each reads the results directory and writes PNG and
PDF into ``<results>/figures``, with the figure's caption beside them (``<stem>.caption``, read by the
report, :mod:`slamarena.experiments.report`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from . import errors, maps, nees, neff, relations, scaling, trajectories, vision
from .runs import FigureSkipped

__all__ = ["FIGURES", "make_all"]

FIGURES: dict[str, Callable[[Path, Path], list[Path]]] = {
    "trajectories": trajectories.plot,
    "errors": errors.plot,
    "nees": nees.plot,
    "scaling": scaling.plot,
    "relations": relations.plot,
    "neff": neff.plot,
    "maps": maps.plot,
    "vo": vision.plot_runs,
}


def make_all(
    results_dir: str | Path, only: list[str] | None = None, verbose: bool = True
) -> tuple[list[Path], dict[str, str]]:
    """Draw the figures (all, or ``only`` these kinds); returns (files written, kind → reason skipped)."""
    results_dir = Path(results_dir)
    out = results_dir / "figures"
    written: list[Path] = []
    skipped: dict[str, str] = {}
    for kind in only or list(FIGURES):
        try:
            files = FIGURES[kind](results_dir, out)
        except FigureSkipped as exc:
            skipped[kind] = str(exc)
            continue
        written += files
        if verbose:
            for f in files:
                print(f"wrote {f}")
    if verbose:
        for kind, reason in skipped.items():
            print(f"skipped {kind}: {reason}")
    return written, skipped
