"""``slamarena params METHOD``: every method's parameters by dotted path, with the method's defaults, units and
descriptions; the paths it prints are what a config and ``slamarena map --param`` take."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from slamarena.experiments.cli import app
from slamarena.experiments.cli_map import parse_params
from slamarena.experiments.cli_params import parameter_rows
from slamarena.experiments.config import method_table
from slamarena.params import parameter_paths, params_model, submodel
from slamarena.targets import import_target


def _rows(output: str) -> dict[str, list[str]]:
    """The printed table as path → [default, unit, description] (columns split at runs of two spaces)."""
    lines = output.splitlines()[2:]
    return {cells[0]: cells[1:] for cells in ([c.strip() for c in line.split("  ") if c.strip()] for line in lines)}


def test_laser_slam_prints_its_nested_defaults_with_units_and_descriptions():
    result = CliRunner().invoke(app, ["params", "laser_slam"])
    assert result.exit_code == 0, result.output
    rows = _rows(result.output)
    assert rows["loop.level"] == ["1", "pyramid level of the branch-and-bound loop search"]
    assert rows["loop.linear_window"] == ["5.0", "m", "most half-width of the loop search in translation (cost)"]
    assert rows["refine.sigma_rotation"][:2] == ["0.002", "rad"]
    assert rows["pyramid.cells.clamp"][0] == "[0.12, 0.97]"
    assert rows["robust_kernel.robust"][0] == '"cauchy"'  # the method's default, not the kernel model's "none"
    assert rows["loop"] == ["the loop-closure search"]  # a section: its description, no default
    # the matcher's parameters, expanded with the descriptions and units of the matcher's own model
    assert rows["frontend.matcher_params.iterations"] == ["10", "most Gauss-Newton iterations per pyramid level"]
    assert rows["frontend.matcher_params.tol_rotation"][:2] == ["0.0001", "rad"]


def test_the_matcher_parameters_follow_the_chosen_matcher():
    from slamarena.mapping.grid_slam import GridSLAM

    rows = {r[0]: r[1:] for r in parameter_rows(GridSLAM.Params(frontend={"matcher": "correlative"}))}
    assert rows["frontend.matcher_params.linear_window"][1] == "m" and "frontend.matcher_params.iterations" not in rows


def test_the_rbpf_shows_its_own_defaults_of_a_shared_sub_model():
    rows = _rows(CliRunner().invoke(app, ["params", "rbpf"]).output)
    assert rows["pyramid.cells.hit_guard"][:2] == ["1", "cells"]
    assert rows["motion.sigma_t_per_m"][:2] == ["0.1", "m/m"]


@pytest.mark.parametrize("method", sorted(method_table()))
def test_every_method_parameter_is_printed_with_a_description_and_its_path_sets_it(method):
    model = params_model(import_target(method_table()[method]))
    rows = {path: (default, unit, text) for path, default, unit, text in parameter_rows(model())}
    canonical = model().canonical()
    for path in parameter_paths(model):
        assert rows[path][2], f"{method}: {path} has no description"
        value, off = canonical, None
        for depth, part in enumerate(path.split(".")):
            if value is None:  # an optional sub-model that is off: its fields show the defaults they take when set
                off = ".".join(path.split(".")[:depth])
                value = submodel(model.model_fields[off].annotation)().canonical()
            value = value[part]
        if not isinstance(value, dict):
            assert json.loads(rows[path][0]) == value
            # the path as --param takes it gives the same parameters back (turning an optional sub-model on, with
            # its defaults)
            given = model.of(parse_params([f"{path}={rows[path][0]}"]))
            expected = model() if off is None else model.of({off: {}})
            assert given == expected


def test_an_unknown_method_names_the_closest():
    result = CliRunner().invoke(app, ["params", "laser_slma"])
    assert result.exit_code == 2 and "did you mean laser_slam?" in result.output
