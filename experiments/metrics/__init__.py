"""Metrics of one cell (an estimate of one method on one dataset and seed).

``METRICS`` maps the name an experiment config uses to a :class:`Metric`: its parameter model
(pydantic, extra keys forbidden), its outputs (name → ("lower" | "higher" | None, what it is);
"better" drives the best-value marks of the tables) and the function that evaluates it.
Each evaluation returns ``(scalars, series)``: scalars go to ``metrics.json`` and the summary,
series (per-step arrays) to ``series.npz`` for the figures and Monte Carlo averages. A metric
that does not apply (no ground truth, no covariance) raises :class:`MetricUnavailable`; the
reason is recorded instead of a number.

Modules: :mod:`.alignment` (Umeyama in 2D), :mod:`.reference` (ground truth at estimate
times), :mod:`.trajectory` (ATE, RPE), :mod:`.trajectory3d` (camera trajectories: 3-D ATE after SE(3)/Sim(3)
alignment, KITTI's relative error and drift), :mod:`.consistency` (NEES, NIS, χ² bands, Monte Carlo),
:mod:`.landmarks` (map error), :mod:`.relations` (Kümmerle et al.; ``loop``: their error on the ground truth's
revisits, a measure of loop closure), :mod:`.reference_relations` (``refrel``: local and loop relations derived from a
SLAM reference and its scans, for the corrected logs), :mod:`.cost`, :mod:`.estimate` (what the
estimate reports of itself: landmark count, rejected rows, an optimiser's final error), :mod:`.occupancy` (the quality
of the occupancy map a laser trajectory implies, without ground truth: :mod:`slamarena.mapping.evaluation`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from slamarena.datasets.estimate import Estimate
from slamarena.params import Params

from .consistency import NEES_OUTPUTS, NIS_OUTPUTS, NEESParams, NISParams, nees, nis
from .cost import COST_OUTPUTS, CostParams, cost
from .estimate import ESTIMATE_OUTPUTS, EstimateParams, estimate_counts
from .landmarks import MAP_OUTPUTS, MapParams, landmark_error
from .occupancy import OCCUPANCY_OUTPUTS, OccupancyParams, occupancy_quality
from .reference import MetricUnavailable, Reference, reference_of
from .reference_relations import REFERENCE_RELATION_OUTPUTS, ReferenceRelationsParams, reference_relation_error
from .relations import (
    LOOP_OUTPUTS,
    RELATION_OUTPUTS,
    LoopParams,
    RelationsParams,
    loop_relation_error,
    relation_error_from_file,
)
from .trajectory import ATE_OUTPUTS, RPE_OUTPUTS, ATEParams, RPEParams, ate, rpe
from .trajectory3d import ATE3D_OUTPUTS, RELATIVE3D_OUTPUTS, ATE3DParams, RelativeErrorParams, ate3d, relative3d

__all__ = ["METRICS", "Metric", "CellData", "MetricUnavailable", "evaluate", "output_columns", "reference_of"]


@dataclass(frozen=True)
class CellData:
    """Everything a metric may read: the estimate, the loaded dataset and its ground truth, costs."""

    estimate: Estimate
    data: Any
    reference: Reference
    wall: float | None = None
    peak_rss: float | None = None


@dataclass(frozen=True)
class Metric:
    params: type[Params]
    outputs: dict[str, tuple[str | None, str]]
    evaluate: Callable[[CellData, Params], tuple[dict, dict]]


METRICS: dict[str, Metric] = {
    "ate": Metric(ATEParams, ATE_OUTPUTS, lambda c, p: ate(c.estimate, c.reference, p)),
    "rpe": Metric(RPEParams, RPE_OUTPUTS, lambda c, p: rpe(c.estimate, c.reference, p)),
    "nees": Metric(NEESParams, NEES_OUTPUTS, lambda c, p: nees(c.estimate, c.reference, p)),
    "nis": Metric(NISParams, NIS_OUTPUTS, lambda c, p: nis(c.estimate, p)),
    "map": Metric(MapParams, MAP_OUTPUTS, lambda c, p: landmark_error(c.estimate, c.reference, p)),
    "relations": Metric(
        RelationsParams, RELATION_OUTPUTS, lambda c, p: relation_error_from_file(c.estimate, c.data, p)
    ),
    "loop": Metric(LoopParams, LOOP_OUTPUTS, lambda c, p: loop_relation_error(c.estimate, c.reference, p)),
    "refrel": Metric(
        ReferenceRelationsParams,
        REFERENCE_RELATION_OUTPUTS,
        lambda c, p: reference_relation_error(c.estimate, c.data, c.reference, p),
    ),
    "cost": Metric(
        CostParams, COST_OUTPUTS, lambda c, p: cost(c.estimate, c.wall, c.peak_rss, p, duration=_duration(c.data))
    ),
    "estimate": Metric(EstimateParams, ESTIMATE_OUTPUTS, lambda c, p: estimate_counts(c.estimate, p)),
    "occupancy": Metric(OccupancyParams, OCCUPANCY_OUTPUTS, lambda c, p: occupancy_quality(c.estimate, c.data, p)),
    "ate3d": Metric(ATE3DParams, ATE3D_OUTPUTS, lambda c, p: ate3d(c.estimate, c.data, p)),
    "kitti_rel": Metric(RelativeErrorParams, RELATIVE3D_OUTPUTS, lambda c, p: relative3d(c.estimate, c.data, p)),
}


def _duration(data) -> float | None:
    """A recording's span [s] (first to last stamp of its streams), ``None`` for data without time (pose graphs)."""
    return data.t1 - data.t0 if hasattr(data, "t1") else None


def output_columns() -> dict[str, tuple[str | None, str]]:
    """Every summary column a metric can produce, ``"<metric>.<output>"`` → (better, description)."""
    return {f"{m}.{k}": v for m, metric in METRICS.items() for k, v in metric.outputs.items()}


def evaluate(cell: CellData, selected: dict[str, Params]) -> tuple[dict, dict, dict]:
    """Evaluate the selected metrics: (scalars by metric, series by metric, skipped reasons)."""
    scalars, series, skipped = {}, {}, {}
    for name, params in selected.items():
        try:
            scalars[name], series[name] = METRICS[name].evaluate(cell, params)
        except MetricUnavailable as exc:
            skipped[name] = str(exc)
    return scalars, series, skipped
