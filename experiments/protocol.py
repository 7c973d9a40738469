"""Leave-one-log-out choice of a method's parameters: the ``protocol:`` section of an experiment config.

A config lists each candidate parameter set of a method as an estimator entry of its own (a label each) and groups
them under ``protocol.candidates`` (method → its candidate labels). Every candidate runs on every dataset (the
ordinary grid, cached as any run). Then, per method and per held-out dataset d, with ``S[e, c]`` the score of
candidate c on dataset e (the first column of ``protocol.score`` the dataset has; lower is better; a failed cell or a
missing number is +∞)::

    chosen(d) = argmin_c  Σ_{e ≠ d} log S[e, c]        (the geometric mean over the other datasets: every dataset
                                                         weighs as a ratio, a log whose errors are metres does not
                                                         outvote one whose errors are centimetres; ties: the first
                                                         candidate declared)
    held_out(d) = S[d, chosen(d)]                       the error on a dataset its parameters were not chosen on
    oracle(d)   = min_c S[d, c]                         the best in hindsight (tuned on d itself), for comparison

The **shipped** candidate of a method is the argmin over all datasets. ``tables/heldout.*`` holds one row per
(dataset, method) and one ``all`` row per method (geometric means of held_out and oracle over the datasets, the
shipped candidate as chosen); ``protocol.json`` the choices and the shipped candidates' parameters.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field

from .results import atomic_write_text
from .tables import write_frame

__all__ = ["ProtocolSpec", "leave_one_out", "write_protocol", "HELDOUT_COLUMNS"]

#: the columns of ``tables/heldout.*`` after dataset and estimator (the method)
HELDOUT_COLUMNS = {
    "score": "the column the dataset is scored by (the first of protocol.score it has)",
    "chosen": "the candidate chosen on the other datasets (row all: the shipped one, chosen on every dataset)",
    "held_out": "the chosen candidate's score on this dataset (row all: geometric mean over the datasets)",
    "oracle": "the best candidate's score on this dataset, tuned on it (row all: geometric mean)",
    "oracle_choice": "that best candidate",
}


class ProtocolSpec(BaseModel):
    """Leave-one-log-out selection (module docstring)."""

    model_config = ConfigDict(extra="forbid")
    kind: str = Field("leave_one_out", pattern="^leave_one_out$", description="the only protocol: leave one log out")
    score: list[str] = Field(
        min_length=1, description="columns, lower is better; each dataset is scored by the first of them it has"
    )
    candidates: dict[str, list[str]] = Field(
        min_length=1, description="method → the estimator labels of its candidate parameter sets (at least 2)"
    )


def _scores(frame: pd.DataFrame, spec: ProtocolSpec, datasets: list[str]) -> tuple[dict[str, str], pd.DataFrame]:
    """(score column per dataset, S[dataset, candidate label]: +∞ where the cell failed or has no number)."""
    labels = [c for cs in spec.candidates.values() for c in cs]
    ok = frame[frame["status"] == "ok"]
    column = {}
    for d in datasets:
        rows = ok[ok["dataset"] == d]
        column[d] = next((c for c in spec.score if c in rows and rows[c].notna().any()), "")
    s = pd.DataFrame(np.inf, index=datasets, columns=labels)
    for _, row in ok.iterrows():
        d, c = row["dataset"], row["estimator"]
        if c in s.columns and d in s.index and column[d]:
            value = row[column[d]]
            s.loc[d, c] = float(value) if np.isfinite(value) else np.inf
    return column, s


def _argmin(log_sum: pd.Series) -> str:
    """The candidate of least summed log score, the first declared on a tie (all +∞: the first)."""
    return str(log_sum.index[int(np.argmin(log_sum.to_numpy()))])


def _geomean(values) -> float:
    v = np.asarray(list(values), dtype=float)
    return float(np.exp(np.mean(np.log(v)))) if v.size and np.all(np.isfinite(v)) and np.all(v > 0) else math.inf


def leave_one_out(frame: pd.DataFrame, spec: ProtocolSpec, datasets: list[str]) -> tuple[pd.DataFrame, dict]:
    """The held-out table (module docstring) and the shipped candidate of each method, from the summary frame."""
    column, s = _scores(frame, spec, datasets)
    scored = [d for d in datasets if column[d]]
    logs = np.log(s.loc[scored].clip(lower=1e-12))
    rows, shipped = [], {}
    for method, labels in spec.candidates.items():
        held, best = [], []
        for d in scored:
            chosen = _argmin(logs.loc[[e for e in scored if e != d], labels].sum())
            oracle = _argmin(s.loc[[d], labels].iloc[0])
            held.append(s.loc[d, chosen])
            best.append(s.loc[d, oracle])
            rows.append([d, method, column[d], chosen, held[-1], best[-1], oracle])
        shipped[method] = _argmin(logs[labels].sum())
        rows.append(["all", method, "geometric mean", shipped[method], _geomean(held), _geomean(best), ""])
    table = pd.DataFrame(rows, columns=["dataset", "estimator", *HELDOUT_COLUMNS])
    table[["held_out", "oracle"]] = table[["held_out", "oracle"]].replace(math.inf, np.nan)
    return table, shipped


def write_protocol(frame: pd.DataFrame, config, out: Path) -> list[Path]:
    """``tables/heldout.*`` and ``protocol.json`` (the choices, and each shipped candidate's parameters as the config
    states them) of a config with a protocol."""
    spec = config.protocol
    table, shipped = leave_one_out(frame, spec, config.dataset_labels())
    paths = write_frame(table, out / "tables" / "heldout")
    by_label = dict(zip(config.estimator_labels(), config.estimators))
    record = {
        "protocol": spec.model_dump(mode="json"),
        "shipped": {m: {"label": c, "params": by_label[c].params} for m, c in shipped.items()},
        "heldout": table.replace(np.nan, None).to_dict(orient="records"),
    }
    atomic_write_text(out / "protocol.json", json.dumps(record, indent=1, default=str))
    return [*paths, out / "protocol.json"]
