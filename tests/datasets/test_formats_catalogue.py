"""The catalogue of real datasets: names, files, readers, the not-found message, and the data CLI."""
from __future__ import annotations

import functools

import pytest
from pydantic import ValidationError

from slamarena import datasets
from slamarena.datasets import DatasetNotFoundError, catalogue, dataroot
from slamarena.datasets.registry import SIMULATORS
from slamarena.params import params_model
from slamarena.targets import import_target
from checks import assert_rejected_naming

EXPECTED = (
    [f"utias:{d}/robot{k}" for d in (1, 6) for k in range(1, 6)] + ["victoria_park"]
    + [f"g2o:{n}" for n in ("intel", "MIT", "CSAIL", "ais2klinik", "manhattan", "city10000", "parking-garage",
                            "sphere2500", "smallGrid3D", "tinyGrid3D", "noisyToyGraph", "pose2example", "w100")]
    + [f"isam:{n}" for n in ("manhattanOlson3500", "city10000", "cityTrees10000", "w20000")]
    + [f"carmen:{n}" for n in ("intel", "fr079", "aces", "mit-csail", "fr-clinic")]
    + [f"carmen-corrected:{n}" for n in ("acapulco", "aces", "belgioioso", "csail", "edmonton", "fhw", "freiburg-079",
                                         "freiburg-101", "freiburg-campus", "infinite-corridor", "intel", "orebro", "seattle")]
)


def test_every_registry_name_is_catalogued_with_a_resolvable_reader():
    assert set(EXPECTED) <= set(catalogue.CATALOGUE)
    for entry in catalogue.CATALOGUE.values():
        assert callable(import_target(entry.reader))
        assert entry.citation and entry.kind and entry.ground_truth
    names = [info.name for info in datasets.available()]
    assert set(names) == set(catalogue.CATALOGUE) | set(SIMULATORS)


#: reader → a dataset it reads and, for a reader with options, a bad value (field, value)
READERS = {
    "slamarena.datasets.formats.mrclam:read": ("utias:1/robot1", None),
    "slamarena.datasets.formats.victoria_park:load": ("victoria_park", ("variant", "isma")),
    "slamarena.datasets.formats.plaza:read": ("plaza:Plaza1", ("strict_time", "sometimes")),
    "slamarena.datasets.formats.g2o:load": ("g2o:intel", None),
    "slamarena.datasets.formats.toro:load": ("g2o:w100", None),
    "slamarena.datasets.formats.isam:load": ("isam:w20000", ("noise", "cov")),
    "slamarena.datasets.formats.carmen:load": ("carmen:intel", ("max_range", -1.0)),
}


def test_every_catalogued_reader_and_simulator_declares_a_params_model():
    assert {entry.reader for entry in catalogue.CATALOGUE.values()} == set(READERS)
    for target in READERS:
        assert not {"paths", "name"} & set(params_model(import_target(target)).model_fields)  # the catalogue supplies them
    for target in SIMULATORS.values():
        model = params_model(import_target(target))
        assert model().seed == 0
        with pytest.raises(ValidationError, match="seed"):
            model(seed=-1)


def test_catalogue_presets_validate_through_the_readers_models():
    for entry in catalogue.CATALOGUE.values():
        resolved = params_model(import_target(entry.reader)).of(entry.arguments).canonical()
        assert {k: resolved[k] for k in entry.arguments} == entry.arguments


@pytest.mark.parametrize("reader", sorted(READERS))
def test_unknown_and_bad_reader_options_are_rejected_naming_the_field(reader, monkeypatch, tmp_path):
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [tmp_path])  # checked before any file is looked for
    name, bad = READERS[reader]
    for field, value in [("bogus_option", 1)] + ([bad] if bad else []):
        assert_rejected_naming(functools.partial(datasets.load, name), **{field: value})


@pytest.mark.parametrize("name,typo", [("victoria_park", {"varient": "isam"}), ("utias:6/robot1", {"directory": "/data"})])
def test_misspelt_reader_keywords_are_errors_not_ignored(name, typo):
    with pytest.raises(ValidationError, match=next(iter(typo))):
        datasets.load(name, **typo)


@pytest.mark.realdata
def test_staged_datasets_are_present():
    if not any((root / rel).exists() for root in dataroot.data_roots() for e in catalogue.CATALOGUE.values() for rel in e.files):
        pytest.skip("no staged dataset file under any data root (a fresh clone: only the GTSAM wheel's data is here)")
    missing = [n for n, e in catalogue.CATALOGUE.items() if not e.present()]
    assert not missing


def test_missing_dataset_names_places_and_fetch_command(monkeypatch, tmp_path):
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [tmp_path])
    with pytest.raises(DatasetNotFoundError) as err:
        datasets.load("g2o:intel")
    message = str(err.value)
    assert str(tmp_path / "sesync_g2o/intel.g2o") in message and "slamarena data fetch g2o:intel" in message


@pytest.mark.realdata
def test_data_cli_list_and_info():
    from typer.testing import CliRunner

    from slamarena.experiments.cli import app

    runner = CliRunner()
    listed = runner.invoke(app, ["data", "list"], env={"COLUMNS": "200"})
    assert listed.exit_code == 0 and "carmen-corrected:intel" in listed.output and "utias:6/robot1" in listed.output
    info = runner.invoke(app, ["data", "info", "g2o:noisyToyGraph"])
    assert info.exit_code == 0 and '"nodes": 4' in info.output
    unknown = runner.invoke(app, ["data", "info", "nope"])
    assert unknown.exit_code == 2 and "unknown dataset 'nope'" in unknown.output
