"""``slamarena data list|info|fetch``."""
from __future__ import annotations

import typer

data_app = typer.Typer(help="Datasets: what is registered, what is present, summaries, downloads.", no_args_is_help=True)
