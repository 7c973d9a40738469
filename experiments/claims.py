"""Claims: what a study's prose asserts, stated in its config and checked against every run of it.

A config's ``claims:`` list holds the findings its pages state in words, each as a bound on one column of the run::

    claims:
      - claim: the per-step reading of Q makes the filter under-confident  # the sentence, as the page says it
        column: nees.mean_over_dof     # <metric>.<output> of summary.csv (table: monte_carlo: a Monte Carlo column)
        rows: outage/per_step          # DATASET/ESTIMATOR shell pattern(s), comma-separated (monte_carlo: …/STATISTIC)
        below: {estimator: true_noise, times: 0.5}   # the same row of another estimator (and/or dataset) × times
      - claim: the filter told the true noise is consistent
        column: nees.mean_over_dof
        rows: outage/true_noise
        above: 0.33                    # or a number; ``below`` and ``above`` together bound both sides
        below: 1.67

A row's value is the mean over the seeds of its successful cells (``summary.csv``, at full precision), or its row of
``tables/monte_carlo.csv`` (``table: monte_carlo``). Every row the pattern matches must hold the bound (strictly).
The config is rejected before anything runs if a claim's rows or its reference name no cell of its grid
(:meth:`Claim.validate_against`); a reduced run keeps the claims that still apply (:meth:`Claim.applies`).

Checked at the end of ``slamarena run`` (a claim that does not hold is listed, and the exit code is 1) and by
``slamarena results [--check]`` for every shipped config with claims whose run is in the results root
(:func:`check_shipped`).
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .metrics import output_columns
from .results import SUMMARY
from .tables import MONTE_CARLO_COLUMNS

__all__ = ["Claim", "Relative", "ClaimResult", "check_claims", "check_shipped", "print_results"]

MONTE_CARLO = "monte_carlo"
_MC_NUMBERS = [c for c in MONTE_CARLO_COLUMNS if c not in ("dataset", "estimator", "statistic")]


class Relative(BaseModel):
    """A bound taken from another row: the claimed row with its dataset and/or estimator replaced, times a factor."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    dataset: str | None = Field(None, description="dataset label of the reference row (default: the claimed row's)")
    estimator: str | None = Field(None, description="estimator label of the reference row (default: the claimed row's)")
    times: float = Field(1.0, gt=0, description="the bound is the reference row's value times this")

    @model_validator(mode="after")
    def _names_a_row(self):
        if self.dataset is None and self.estimator is None:
            raise ValueError("a relative bound names the reference row's dataset, estimator or both")
        return self

    def reference(self, key: str) -> str:
        """The reference row's key for the claimed row ``key`` (``dataset/estimator[/statistic]``)."""
        parts = key.split("/")
        parts[0] = self.dataset or parts[0]
        parts[1] = self.estimator or parts[1]
        return "/".join(parts)

    def describe(self) -> str:
        row = "/".join([self.dataset or "(same dataset)", self.estimator or "(same estimator)"])
        return f"{self.times:g} × {row}" if self.times != 1 else row


class Claim(BaseModel):
    """One finding as a bound on one column: every row ``rows`` matches is below and/or above its bound."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    claim: str = Field(min_length=1, description="the finding in words, as the page states it")
    column: str = Field(description="<metric>.<output> (summary.csv), or a Monte Carlo column with table: monte_carlo")
    rows: str = Field(min_length=1, description="DATASET/ESTIMATOR shell patterns, comma-separated (+ /STATISTIC)")
    table: Literal["summary", "monte_carlo"] = "summary"
    below: float | Relative | None = None
    above: float | Relative | None = None

    @field_validator("rows")
    @classmethod
    def _row_patterns(cls, rows):
        for pattern in rows.split(","):
            if pattern.count("/") not in (1, 2):
                raise ValueError(f"rows pattern {pattern!r} is not DATASET/ESTIMATOR (or DATASET/ESTIMATOR/STATISTIC)")
        return rows

    @model_validator(mode="after")
    def _bounded(self):
        if self.below is None and self.above is None:
            raise ValueError(f"claim {self.claim!r}: give 'below', 'above' or both")
        known = _MC_NUMBERS if self.table == MONTE_CARLO else list(output_columns())
        if self.column not in known:
            raise ValueError(f"claim {self.claim!r}: unknown column {self.column!r} for table {self.table}")
        return self

    def bounds(self) -> list[tuple[str, float | Relative]]:
        return [(side, b) for side, b in (("above", self.above), ("below", self.below)) if b is not None]

    def _matches(self, key: str) -> bool:
        if self.table == MONTE_CARLO:
            return any(fnmatch.fnmatchcase(key + "/nees", p) or fnmatch.fnmatchcase(key + "/nis", p) for p in self._p())
        return any(fnmatch.fnmatchcase(key, p) for p in self._p())

    def _p(self) -> list[str]:
        return self.rows.split(",")

    def applies(self, cells: set[str]) -> bool:
        """Whether the grid's ``dataset/estimator`` keys hold a row this claim matches and every reference it needs."""
        matched = [k for k in cells if self._matches(k)]
        return bool(matched) and all(
            b.reference(k) in cells for _, b in self.bounds() if isinstance(b, Relative) for k in matched
        )

    def validate_against(self, cells: set[str]) -> None:
        """A ValueError naming the problem if this claim cannot be checked on a grid of these cells."""
        matched = sorted(k for k in cells if self._matches(k))
        if not matched:
            raise ValueError(
                f"claim {self.claim!r}: rows={self.rows} matches no cell of the grid ({', '.join(sorted(cells))})"
            )
        for _, b in self.bounds():
            if isinstance(b, Relative):
                missing = sorted({b.reference(k) for k in matched} - cells)
                if missing:
                    raise ValueError(
                        f"claim {self.claim!r}: the reference row(s) {', '.join(missing)} are not in the grid"
                    )


@dataclass(frozen=True)
class ClaimResult:
    """One claim on one row: the value, each bound it was held to, and whether it holds."""

    claim: str
    column: str
    row: str
    value: float
    bounds: tuple[str, ...]  # "below 0.5 × outage/true_noise = 1.4" …
    holds: bool

    def line(self) -> str:
        verdict = "holds" if self.holds else "DOES NOT HOLD"
        return f"{verdict}: {self.claim} — {self.row} {self.column} = {self.value:.4g}, {' and '.join(self.bounds)}"


def _values(claim: Claim, out: Path) -> pd.Series:
    """The column's value of every row of the run (key → value)."""
    if claim.table == MONTE_CARLO:
        frame = pd.read_csv(out / "tables" / "monte_carlo.csv")
        keys = frame["dataset"] + "/" + frame["estimator"] + "/" + frame["statistic"]
        return pd.Series(frame[claim.column].to_numpy(float), index=keys)
    frame = pd.read_csv(out / SUMMARY)
    frame = frame[frame["status"] == "ok"]
    if claim.column not in frame:
        return pd.Series(dtype=float)
    means = frame.groupby(["dataset", "estimator"])[claim.column].mean()
    return pd.Series(means.to_numpy(float), index=[f"{d}/{e}" for d, e in means.index])


def check_claims(claims: list[Claim], out: Path) -> list[ClaimResult]:
    """Every claim on every row it matches in the run at ``out``; a row without a value (its cells failed, the metric
    was skipped) or a reference without one does not hold."""
    results = []
    for claim in claims:
        values = _values(claim, Path(out))
        rows = sorted(k for k in values.index if any(fnmatch.fnmatchcase(k, p) for p in claim.rows.split(",")))
        if not rows:
            results.append(
                ClaimResult(claim.claim, claim.column, claim.rows, float("nan"), ("no such row in the run",), False)
            )
        for key in rows:
            value, holds, said = float(values[key]), True, []
            for side, bound in claim.bounds():
                if isinstance(bound, Relative):
                    ref = bound.reference(key)
                    limit = bound.times * float(values.get(ref, float("nan")))
                    said.append(
                        f"{side} {bound.times:g} × {ref} = {limit:.4g}"
                        if bound.times != 1
                        else f"{side} {ref} = {limit:.4g}"
                    )
                else:
                    limit = bound
                    said.append(f"{side} {limit:g}")
                holds &= bool(value < limit if side == "below" else value > limit)  # NaN on either side: False
            results.append(ClaimResult(claim.claim, claim.column, key, value, tuple(said), holds))
    return results


def print_results(results: list[ClaimResult], name: str, echo=print, every: bool = True) -> bool:
    """Print the verdicts under the experiment's name, those that do not hold first (``every=False``: only those);
    True if every claim holds."""
    failed = [r for r in results if not r.holds]
    if failed:
        echo(f"{name}: {len(failed)} of {len(results)} claim checks do not hold (the config's claims: in its YAML):")
    else:
        echo(f"{name}: all {len(results)} claim checks hold")
    for r in failed + ([r for r in results if r.holds] if every else []):
        echo(f"  {r.line()}")
    return not failed


def check_shipped(root: Path, echo=print) -> int:
    """``slamarena results``: the claims of every shipped config that has some, on its run under ``root`` (a run that
    is missing, or not of the shipped config, is listed as not checked). Returns 1 if a claim does not hold."""
    from .config import load_config, shipped_configs
    from .quote import not_shipped

    status = 0
    for name in shipped_configs():
        config = load_config(name)
        if not config.claims:
            continue
        run = Path(root) / name
        if not (run / SUMMARY).is_file():
            echo(f"{name}: claims not checked (no run at {run}: `slamarena run {name}`)")
            continue
        if differs := not_shipped(run):
            echo(f"{name}: claims not checked ({run} is not a run of the shipped config: {'; '.join(differs[:2])})")
            continue
        status |= int(not print_results(check_claims(config.claims, run), name, echo, every=False))
    return status
