"""``slamarena identify-noise DATASET``: a sensor model identified by the innovation likelihood of EKF-SLAM with the
data's landmark ids (:mod:`slamarena.experiments.noise_identification`), printed as JSON to state once in a config.

Each ``--entry NAME=I,J`` identifies diagonal entries I, J of the covariance parameter NAME of
:class:`~slamarena.estimators.ekf_slam.EKFSLAMParams`; its stated value is the ``--param NAME=…`` given, else the
sequence's stated noise (:data:`STATED`). ``experiments/configs/victoria_park.yaml``'s identified model is::

    slamarena identify-noise victoria_park --entry range_bearing_cov=0 --entry increment_cov=0,1,2 \\
        --param range_bearing_noise=cartesian --param known_confidence=null
"""

from __future__ import annotations

import json

import numpy as np

from slamarena.errors import UserError

__all__ = ["STATED", "parse_entries", "identify_noise_command"]

#: the sequence's stated value of each covariance parameter that can be identified without a --param
STATED = {
    "range_bearing_cov": lambda seq: seq.noise.range_bearing_cov,
    "twist_cov": lambda seq: seq.noise.twist_cov,
    "increment_cov": lambda seq: seq.motion.cov[0],  # the first increment's: the stated model of every increment
}


def parse_entries(pairs: list[str]) -> dict[str, list[int]]:
    """``NAME=I,J`` pairs of ``--entry`` → {NAME: [I, J]}."""
    out: dict[str, list[int]] = {}
    for pair in pairs:
        name, sep, indices = pair.partition("=")
        try:
            out[name.strip()] = [int(i) for i in indices.split(",")]
        except ValueError:
            sep = ""
        if not sep or not name.strip():
            raise UserError(f"--entry {pair!r}: write NAME=I,J (a covariance parameter and diagonal indices)")
    if not out:
        raise UserError("give at least one --entry NAME=I,J")
    return out


def identify_noise_command(
    dataset: str,
    entries: dict[str, list[int]],
    params: dict,
    dataset_params: dict,
    step: float = 4.0,
    max_exponent: int = 6,
) -> str:
    """The identification as JSON: exponents (NAME[I] → k), the model (NAME → matrix), its score, models evaluated."""
    from slamarena import datasets

    from .noise_identification import identify

    seq = datasets.load(dataset, **dataset_params)
    stated = {}
    for name in entries:
        if name in params:
            stated[name] = np.asarray(params.pop(name), dtype=float)
        elif name in STATED and (value := STATED[name](seq)) is not None:
            stated[name] = np.asarray(value, dtype=float)
        else:
            raise UserError(f"--entry {name}: {dataset} states no {name}; give it with --param {name}=[[...], ...]")
    try:
        found = identify(seq, params, stated, entries, step=step, max_exponent=max_exponent)
    except ValueError as exc:
        raise UserError(str(exc)) from exc
    return json.dumps(
        {
            "dataset": dataset,
            "exponents": {f"{name}[{i}]": k for (name, i), k in found.exponents.items()},
            "step": step,
            "model": {name: m.tolist() for name, m in found.model.items()},
            "score": vars(found.score),
            "models_evaluated": len(found.trace),
        },
        indent=2,
    )
