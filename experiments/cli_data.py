"""``slamarena data list|info|fetch``."""

from __future__ import annotations

import typer

data_app = typer.Typer(
    help="Datasets: what is registered, what is present, summaries, downloads.", no_args_is_help=True
)


@data_app.command("list")
def list_datasets():
    """Every registered dataset: kind, ground truth, whether its files are present."""
    from rich.console import Console
    from rich.table import Table

    from slamarena.datasets import available

    table = Table(title="slamarena datasets")
    for column in ("name", "kind", "ground truth", "present"):
        table.add_column(column)
    for info in available():
        table.add_row(info.name, info.kind, info.ground_truth, "yes" if info.present else "[red]no[/red]")
    Console().print(table)


@data_app.command("info")
def info(
    name: str = typer.Argument(..., help="A registry name, e.g. utias:6/robot1, carmen:intel or bag:/data/run.bag."),
):
    """Load a dataset and print its summary (counts, time span, rates, noise, what the reader dropped); a bag first
    lists its topics: types, counts, rates, time span, stamp source and stamp anomalies."""
    import json

    import numpy as np
    from rich.console import Console

    from slamarena.datasets import load

    console = Console()

    def plain(x):
        return x.tolist() if isinstance(x, np.ndarray) else x.item() if isinstance(x, np.generic) else str(x)

    if name.partition(":")[0] == "bag":  # the bag as recorded first: a reader's refusal (stamps stepping back) follows
        from .cli_bag import print_survey

        print_survey(console, name)
    data = load(name)  # a bad name, missing files or a malformed file is a UserError: one message, exit code 2
    summary = data.summary()
    console.print_json(json.dumps(summary, default=plain))


@data_app.command("fetch")
def fetch(
    name: str = typer.Argument(..., help="A registry name (see `slamarena data list`)."),
    force: bool = typer.Option(False, "--force", help="Download even when a data root already has the files."),
):
    """Download a dataset's files (pinned commit URLs, sha256-checked) into the cache data root."""
    from rich.console import Console

    from slamarena.datasets.fetch import fetch as do_fetch

    console = Console()
    for p in do_fetch(name, force=force):
        console.print(str(p))
