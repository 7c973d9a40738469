"""The estimator protocol: ``run(sequence) -> Estimate``.

Online filters also expose ``predict(...)`` and ``update(...)`` for interactive use.
:class:`~slamarena.datasets.estimate.Estimate` documents the result.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.sequence import Sequence

__all__ = ["Estimate", "Estimator"]


@runtime_checkable
class Estimator(Protocol):
    def run(self, sequence: Sequence) -> Estimate: ...
