"""notebook/2026-11-28-generalisation.md: the held-out table of the ``generalisation`` config from the cells finished
so far, without running any.

Run from the repository root: ``python research/scripts/generalisation_heldout.py LABEL … [--datasets D1,D2,…]``
(estimator labels and dataset labels of the config; the cells under ``results/generalisation``). Prints the
leave-one-log-out table (:func:`slamarena.experiments.protocol.leave_one_out`) of the methods named, over the
datasets named, and each cell's score; a cell not finished counts as failed (+∞).
"""

import sys
from pathlib import Path

from slamarena.experiments.config import load_config
from slamarena.experiments.plan import plan
from slamarena.experiments.protocol import leave_one_out
from slamarena.experiments.tables import collect, format_number


def main(args: list[str]) -> None:
    datasets = None
    if "--datasets" in args:
        at = args.index("--datasets")
        datasets, args = args[at + 1].split(","), args[:at] + args[at + 2 :]
    config = load_config("generalisation").reduced(datasets=datasets, estimators=args)
    cells = plan(config, Path("results/generalisation"))
    done = [c for c in cells if c.finished()]
    frame = collect(config, done, {})
    print(f"{len(done)} of {len(cells)} cells finished")
    table, shipped = leave_one_out(frame, config.protocol, config.dataset_labels())
    print("| " + " | ".join(table.columns) + " |")
    print("|" + "---|" * len(table.columns))
    for row in table.itertuples(index=False):
        print("| " + " | ".join(format_number(v) if isinstance(v, float) else str(v) for v in row) + " |")
    print("shipped:", shipped)
    score = [c for c in config.protocol.score if c in frame]
    wide = frame.assign(score=frame[score].bfill(axis=1).iloc[:, 0]).pivot(
        index="dataset", columns="estimator", values="score"
    )
    print(wide.reindex(config.dataset_labels()).to_string(float_format=lambda v: f"{v:.4f}"))


if __name__ == "__main__":
    main(sys.argv[1:])
