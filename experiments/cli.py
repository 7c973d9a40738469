"""The ``slamarena`` command line (typer, rich output).

Commands delegate to the modules that own the work, imported inside each command so that
``slamarena --help`` starts without loading numpy-heavy or GTSAM/Open3D code:

    slamarena run [CONFIG]            slamarena.experiments.cli_run
    slamarena figures RESULTS_DIR     slamarena.paper_figures.make
    slamarena report RESULTS_DIR [B]  slamarena.experiments.report
    slamarena results [PAGE…]         slamarena.experiments.quote (the quoted tables and numbers of README and research/)
    slamarena data list|info|fetch    slamarena.experiments.cli_data
    slamarena bench NAME              slamarena.experiments.benchmarks (the BENCHMARKS table)
    slamarena map LOG                 slamarena.experiments.cli_map
    slamarena eval TRAJ --ref REF     slamarena.experiments.cli_eval (any trajectory file against a reference)
    slamarena params METHOD           slamarena.experiments.cli_params

(``figures`` reaches one layer up, into ``paper_figures``: the CLI is the top of the stack.)
"""

from __future__ import annotations

from pathlib import Path

import typer
from typer.core import TyperGroup

from .cli_data import data_app


class _Commands(TyperGroup):
    """The command group: a :class:`~slamarena.errors.UserError` (a bad file, a missing dataset, a bad config or
    option) prints its message and exits with code 2; any other exception is a bug and keeps its traceback. The message
    is printed unwrapped (``soft_wrap``): a path in it stays one piece to copy, however narrow the console."""

    def invoke(self, ctx):
        from slamarena.errors import UserError

        try:
            return super().invoke(ctx)
        except UserError as exc:
            from rich.console import Console
            from rich.markup import escape

            Console(stderr=True, soft_wrap=True).print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
            raise typer.Exit(2) from None


app = typer.Typer(
    cls=_Commands,
    name="slamarena",
    help="Comparative SLAM research: EKF-SLAM, an EKF localizer, GTSAM smoothers and grid mapping on shared datasets.",
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
)
app.add_typer(data_app, name="data")


def _version(value: bool) -> None:
    if value:
        from slamarena import __version__

        typer.echo(f"slamarena {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(
    data_root: Path | None = typer.Option(
        None, "--data-root", help="Directory holding the datasets (before SLAMARENA_DATA and the defaults)."
    ),
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
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

    from .cli_run import run_from_cli

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
    log: str = typer.Argument(
        ...,
        help="A CARMEN log or ROS bag path, or a registry name such as carmen:intel, bag:/data/run.bag or sim:laser.",
    ),
    method: str = typer.Option(
        "grid_slam",
        "--method",
        help="Mapping method: grid_slam (front end alone), laser_slam (with loop closure), rbpf.",
    ),
    param: list[str] = typer.Option(
        [],
        "--param",
        help="A parameter of the method, key=value (repeatable), a sub-model's by its dotted path as `slamarena params "
        "METHOD` prints it, e.g. --param loop.level=2 --param pyramid.resolution=0.1.",
    ),
    matcher: str | None = typer.Option(
        None,
        "--matcher",
        help="Scan matcher of grid_slam and laser_slam (short for --param frontend.matcher=NAME): gauss_newton, "
        "correlative, branch_and_bound, kiss_icp, open3d_icp, point_to_line.",
    ),
    particles: int | None = typer.Option(
        None, "--particles", help="Particles of a particle filter (short for --param particles=N)."
    ),
    out: Path = typer.Option(Path("results/maps"), "--out", help="Output directory."),
    relations: Path | None = typer.Option(
        None, "--relations", help="A Kümmerle et al. relations file to score the trajectory against."
    ),
    mcap: bool = typer.Option(
        False, "--mcap", help="Also write result.mcap (trajectory, tf, grid) for Foxglove / RViz 2."
    ),
):
    """A laser mapping method over a log: trajectory, map PNG/PGM, pose graph, timing."""
    from .cli_map import map_command, parse_params

    shorthands = (("frontend.matcher", matcher), ("particles", particles))
    params = parse_params(param + [f"{key}={value}" for key, value in shorthands if value is not None])
    raise typer.Exit(map_command(log, method=method, params=params, out=out, relations=relations, mcap=mcap))


@app.command("eval")
def eval_trajectory(
    traj: Path = typer.Argument(
        ..., help="A trajectory file: TUM, KITTI poses, EuRoC CSV or g2o (by suffix or --format)."
    ),
    ref: str = typer.Option(..., "--ref", help="A trajectory file, or a dataset name (its ground truth / relations)."),
    metrics: str = typer.Option("ate,rpe", "--metrics", help="Comma-separated metric names, e.g. ate,rpe,relations."),
    format: str | None = typer.Option(None, "--format", help="TRAJ's format: tum, kitti, euroc, g2o."),
    ref_format: str | None = typer.Option(None, "--ref-format", help="The reference file's format."),
    ref_param: list[str] = typer.Option(
        [], "--ref-param", help="An option of the reference dataset's reader, key=value (repeatable): truth_topic=/gt."
    ),
    times: Path | None = typer.Option(None, "--times", help="KITTI stamps (times.txt) for TRAJ; default the index."),
    kitti_frame: str = typer.Option(
        "xy", "--kitti-frame", help="KITTI poses: xy (planar, z up) or camera (KITTI odometry ground truth)."
    ),
    max_tilt: float = typer.Option(
        1e-6, "--max-tilt", help="Largest tilt out of the x-y plane [rad] projected; a larger one is refused."
    ),
    align: str = typer.Option("se2", "--align", help="ATE alignment: none, se2, sim2 (as in configs)."),
    max_gap: float = typer.Option(0.1, "--max-gap", help="Seconds from an estimate to the reference around it."),
    rpe_delta: float = typer.Option(1.0, "--rpe-delta", help="RPE pair distance (in --rpe-unit)."),
    rpe_unit: str = typer.Option("s", "--rpe-unit", help="RPE pair distance unit: frames, s, m."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
):
    """Score a trajectory from any system against a dataset's ground truth or a reference file."""
    from .cli_eval import eval_command, evaluate_file
    from .cli_map import parse_params

    params = {
        "ate": {"align": align, "max_gap": max_gap},
        "rpe": {"delta": rpe_delta, "unit": rpe_unit, "max_gap": max_gap},
    }
    names = [m.strip() for m in metrics.split(",") if m.strip()]
    result = evaluate_file(
        traj,
        ref,
        names,
        params,
        traj_format=format,
        ref_format=ref_format,
        times=times,
        ref_params=parse_params(ref_param),
        kitti_frame=kitti_frame,
        max_tilt=max_tilt,
    )
    raise typer.Exit(eval_command(result, as_json))


@app.command("identify-noise")
def identify_noise(
    dataset: str = typer.Argument(..., help="A dataset with landmark ids, e.g. victoria_park or sim:landmarks."),
    entry: list[str] = typer.Option(
        ..., "--entry", help="Diagonal entries to identify, NAME=I,J (repeatable), e.g. increment_cov=0,1,2."
    ),
    param: list[str] = typer.Option(
        [],
        "--param",
        help="An EKF-SLAM parameter, key=value (repeatable); an identified one's value is its stated start.",
    ),
    dataset_param: list[str] = typer.Option(
        [], "--dataset-param", help="A dataset keyword, key=value (repeatable), e.g. n_landmarks=20 for sim:landmarks."
    ),
    step: float = typer.Option(4.0, "--step", help="Grid factor between neighbouring models."),
    max_exponent: int = typer.Option(6, "--max-exponent", help="Largest |k| of a factor step**k."),
):
    """A sensor model identified by EKF-SLAM's innovation likelihood with the data's landmark ids (JSON)."""
    from .cli_map import parse_params
    from .cli_noise import identify_noise_command, parse_entries

    typer.echo(
        identify_noise_command(
            dataset, parse_entries(entry), parse_params(param), parse_params(dataset_param), step, max_exponent
        )
    )


@app.command("params")
def params(
    method: str = typer.Argument(..., help="A method name of an experiment config (e.g. laser_slam, rbpf, ekf_slam)."),
):
    """A method's parameters, nested as a config's params: takes them, with defaults, units and descriptions."""
    from .cli_params import params_command

    typer.echo(params_command(method))


def main() -> None:
    app()
