"""notebook/2026-11-28-generalisation.md: the shipped ``generalisation`` config on a part of its grid.

Run from the repository root: ``python research/scripts/generalisation_subset.py LABEL … [--datasets D1,D2,…]
[--recompute L1,L2,…]`` (estimator labels of the config, e.g. ``odometry grid_slam_w10``; dataset labels, default all;
the methods whose cells are recomputed even if cached). The cells go to
``results/generalisation``, the shipped config's directory, with the same cache keys as a full run: ``slamarena run
generalisation`` afterwards runs only the cells left and writes the held-out table over every method.
"""

import sys
from pathlib import Path

from slamarena.experiments.config import load_config
from slamarena.experiments.runner import run_experiment


def _option(args: list[str], name: str) -> tuple[list[str] | None, list[str]]:
    if name not in args:
        return None, args
    at = args.index(name)
    return args[at + 1].split(","), args[:at] + args[at + 2 :]


def main(args: list[str]) -> int:
    datasets, args = _option(args, "--datasets")
    recompute, args = _option(args, "--recompute")
    config = load_config("generalisation").reduced(datasets=datasets, estimators=args)
    return run_experiment(config, Path("results/generalisation"), jobs=1, recompute=frozenset(recompute or ()))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
