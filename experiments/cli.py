"""The ``slamarena`` command line (typer, rich output).

Commands delegate to the modules that own the work, imported inside each command so that
``slamarena --help`` starts without loading numpy-heavy or GTSAM/Open3D code:

    slamarena run [CONFIG]            slamarena.experiments.runner
    slamarena figures RESULTS_DIR     slamarena.paper_figures.make
    slamarena report RESULTS_DIR [B]  slamarena.experiments.report
    slamarena results [PAGE…]         slamarena.experiments.quote (the quoted tables and numbers of README and research/)
    slamarena data list|info|fetch    slamarena.experiments.cli_data
    slamarena bench NAME              slamarena.experiments.benchmarks (the BENCHMARKS table)
    slamarena map LOG                 slamarena.experiments.cli_map

(``figures`` reaches one layer up, into ``paper_figures``: the CLI is the top of the stack.)
"""

from __future__ import annotations

from pathlib import Path

import typer
from typer.core import TyperGroup

from .cli_data import data_app


class _Commands(TyperGroup):
    """The command group: a :class:`~slamarena.errors.UserError` (a bad file, a missing dataset, a bad config or
    option) prints its message and exits with code 2; any other exception is a bug and keeps its traceback."""

    def invoke(self, ctx):
        from slamarena.errors import UserError

        try:
            return super().invoke(ctx)
        except UserError as exc:
            from rich.console import Console
            from rich.markup import escape

            Console(stderr=True).print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
            raise typer.Exit(2) from None


app = typer.Typer(
    cls=_Commands,
    name="slamarena",
    help="Comparative SLAM research: EKF-SLAM, an EKF localizer, GTSAM smoothers and grid mapping on shared datasets.",
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
)
app.add_typer(data_app, name="data")


@app.callback()
def _main(
    data_root: Path | None = typer.Option(
        None, "--data-root", help="Directory holding the datasets (before SLAMARENA_DATA and the defaults)."
    ),
):
    if data_root is not None:
        from slamarena.datasets.dataroot import set_data_root

        set_data_root(data_root)


@app.command()
def run(
    config: Path | None = typer.Argument(None, help="Experiment YAML (default: the shipped default.yaml)."),
    jobs: int = typer.Option(1, "--jobs", "-j", help="Cells run in parallel (local processes)."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Dask distributed scheduler address: run the cells on that cluster."
    ),
    out: Path | None = typer.Option(None, "--out", help="Results directory (default: the config's output directory)."),
    force: bool = typer.Option(False, "--force", help="Recompute cells that are already cached."),
    recompute: list[str] | None = typer.Option(
        None,
        "--recompute",
        help="Recompute the cached cells of this method label (repeatable): "
        "the cache key does not change with the code, so do this after changing a method.",
    ),
    dry_run: bool = typer.Option(False, "--dry-run", help="Print the grid of runs and exit."),
    report: bool = typer.Option(
        False, "--report", help="At the end, write the HTML report and its Markdown twin (report.html, report.md)."
    ),
    list_configs: bool = typer.Option(False, "--list", help="List the shipped configs, one line each, and exit."),
    seeds: int | None = typer.Option(
        None,
        "--seeds",
        min=1,
        help="Run seeds 0 … N−1 instead of the config's seeds (a reduced run; the manifest records it).",
    ),
):
    """Run an experiment: every method on every dataset and seed; write tables and figures."""
    if list_configs:
        from .config import shipped_configs

        configs = shipped_configs()
        width = max(map(len, configs))
        for name, description in configs.items():
            typer.echo(f"{name:<{width}}  {description}")
        raise typer.Exit(0)
    from slamarena.paper_figures.make import make_all

    from .runner import run_from_cli

    raise typer.Exit(
        run_from_cli(
            config=config,
            jobs=jobs,
            scheduler=scheduler,
            out=out,
            force=force,
            dry_run=dry_run,
            make_figures=make_all,
            report=report,
            seeds=seeds,
            recompute=tuple(recompute or ()),
        )
    )


@app.command()
def figures(
    results_dir: Path = typer.Argument(..., exists=True, file_okay=False, help="A results/<experiment> directory."),
):
    """Regenerate every figure of a results directory (PNG and PDF); an error when none can be drawn."""
    from slamarena.errors import UserError
    from slamarena.paper_figures.make import make_all

    written, skipped = make_all(results_dir)
    if not written:
        reasons = "; ".join(f"{kind}: {why}" for kind, why in skipped.items())
        raise UserError(f"{results_dir}: no figure could be drawn ({reasons})")


@app.command()
def report(
    results_dir: Path = typer.Argument(..., exists=True, file_okay=False, help="A results/<experiment> directory."),
    other: Path | None = typer.Argument(
        None,
        exists=True,
        file_okay=False,
        help="A second results directory of the same config: A and B side by side, differences highlighted.",
    ),
    out: Path | None = typer.Option(
        None,
        "--out",
        help="Where to write (suffix replaced by .html and .md); default RESULTS_DIR/report or RESULTS_DIR/report_vs_<B>.",
    ),
):
    """Write one self-contained HTML report (figures embedded; open it in any browser, offline) and its Markdown twin."""
    from .report import write_report

    html, md = write_report(results_dir, other, out)
    typer.echo(f"wrote {html}\nwrote {md}\nopen it in a browser: {html.resolve().as_uri()}")


@app.command()
def results(
    pages: list[Path] | None = typer.Argument(
        None,
        help="The pages whose quoted tables and values to regenerate (default: README.md and every research page with a marker).",
    ),
    root: Path = typer.Option(Path("results"), "--results", help="Where the runs are: ROOT/<experiment>/tables/."),
    strict: bool = typer.Option(
        False, "--strict", help="A quoted run that is missing is an error (default: its text is kept, and listed)."
    ),
    check: bool = typer.Option(
        False,
        "--check",
        help="Change nothing; list the tables with only a new provenance line (same numbers) and the changed numbers; "
        "exit 1 if a number changed.",
    ),
    reduced: bool = typer.Option(
        False,
        "--reduced",
        help="Quote runs made with other settings than the shipped config's too (e.g. --seeds), marked †.",
    ),
):
    """Regenerate the tables and numbers a page quotes (between its <!-- table: … --> / <!-- value: … --> markers) from the runs."""
    from .quote import quote_main

    raise typer.Exit(quote_main(pages or None, root, strict=strict, check=check, reduced=reduced))


@app.command()
def bench(
    name: str = typer.Argument(..., help="Benchmark name (see `slamarena bench list`)."),
    out: Path | None = typer.Option(None, "--out", help="Directory for the benchmark's CSV and plot."),
    quick: bool = typer.Option(False, "--quick", help="A smaller problem, for a fast look."),
):
    """Timing benchmarks that print ratios and scaling exponents measured in one run."""
    from .benchmarks import run_benchmark

    raise typer.Exit(run_benchmark(name, out=out, quick=quick))


@app.command("map")
def map_log(
    log: str = typer.Argument(..., help="A CARMEN log path, or a registry name such as carmen:intel or sim:laser."),
    method: str = typer.Option(
        "grid_slam",
        "--method",
        help="Mapping method: grid_slam (front end alone), laser_slam (with loop closure), rbpf.",
    ),
    param: list[str] = typer.Option(
        [], "--param", help="A parameter of the method, key=value (repeatable), e.g. --param matcher=branch_and_bound."
    ),
    matcher: str | None = typer.Option(
        None,
        "--matcher",
        help="Scan matcher (short for --param matcher=NAME): gauss_newton, correlative, branch_and_bound, kiss_icp, open3d_icp, point_to_line.",
    ),
    particles: int | None = typer.Option(
        None, "--particles", help="Particles of a particle filter (short for --param particles=N)."
    ),
    out: Path = typer.Option(Path("results/maps"), "--out", help="Output directory."),
    relations: Path | None = typer.Option(
        None, "--relations", help="A Kümmerle et al. relations file to score the trajectory against."
    ),
):
    """A laser mapping method over a log: trajectory, map PNG/PGM, pose graph, timing."""
    from .cli_map import map_command, parse_params

    params = parse_params(param)
    params.update({k: v for k, v in (("matcher", matcher), ("particles", particles)) if v is not None})
    raise typer.Exit(map_command(log, method=method, params=params, out=out, relations=relations))


def main() -> None:
    app()
