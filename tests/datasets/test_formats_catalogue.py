"""The catalogue of real datasets and the format families: names, files (all from one root), readers, recordings at a
path, the not-found message, and the data CLI."""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
from checks import assert_rejected_naming, load_staged
from pydantic import ValidationError

from slamarena import datasets
from slamarena.datasets import DatasetNameError, DatasetNotFoundError, catalogue, dataroot
from slamarena.datasets.registry import SIMULATORS, resolve
from slamarena.datasets.source import SourceParams
from slamarena.params import params_model
from slamarena.targets import import_target

EXPECTED = (
    [f"utias:{d}/robot{k}" for d in (1, 6) for k in range(1, 6)]
    + ["victoria_park", "victoria_park:isam"]
    + [
        f"g2o:{n}"
        for n in (
            "intel",
            "MIT",
            "CSAIL",
            "ais2klinik",
            "manhattan",
            "city10000",
            "parking-garage",
            "sphere2500",
            "smallGrid3D",
            "tinyGrid3D",
            "noisyToyGraph",
            "pose2example",
            "w100",
        )
    ]
    + [f"isam:{n}" for n in ("manhattanOlson3500", "city10000", "cityTrees10000", "w20000")]
    + ["carpark"]
    + [f"carmen:{n}" for n in ("intel", "fr079", "aces", "mit-csail", "fr-clinic")]
    + [
        f"carmen-corrected:{n}"
        for n in (
            "acapulco",
            "aces",
            "belgioioso",
            "csail",
            "edmonton",
            "fhw",
            "freiburg-079",
            "freiburg-101",
            "freiburg-campus",
            "infinite-corridor",
            "intel",
            "orebro",
            "seattle",
        )
    ]
)


def test_every_registry_name_is_catalogued_with_a_resolvable_reader():
    assert set(EXPECTED) <= set(catalogue.CATALOGUE)
    for entry in catalogue.CATALOGUE.values():
        assert callable(import_target(entry.reader))
        assert entry.citation and entry.kind and entry.ground_truth
    names = [info.name for info in datasets.available()]
    assert set(names) == set(catalogue.CATALOGUE) | set(SIMULATORS)


#: reader → a catalogued dataset it reads, the same family at a path, and for a reader with options a bad value (field, value)
READERS = {
    "slamarena.datasets.formats.mrclam:read": ("utias:1/robot1", "utias:/nowhere/robot1", None),
    "slamarena.datasets.formats.victoria_park:load": (
        "victoria_park",
        "victoria_park:/nowhere.txt",
        ("variant", "isma"),
    ),
    "slamarena.datasets.formats.plaza:read": ("plaza:Plaza1", "plaza:/nowhere/Plaza3", ("strict_time", "sometimes")),
    "slamarena.datasets.formats.g2o:load": ("g2o:intel", "g2o:/nowhere.g2o", None),
    "slamarena.datasets.formats.toro:load": ("g2o:w100", "toro:/nowhere.graph", None),
    "slamarena.datasets.formats.isam:load": ("isam:w20000", "isam:/nowhere.txt", ("noise", "cov")),
    "slamarena.datasets.formats.carmen:load": ("carmen:intel", "carmen:/nowhere.clf", ("max_range", -1.0)),
    "slamarena.datasets.formats.bag:load": ("bag:aces", "bag:/nowhere.bag", ("stamps", "sometimes")),
    "slamarena.datasets.formats.kitti_odometry:read": ("kitti:00", "kitti:/nowhere/sequences/00", ("frames", 1)),
    "slamarena.datasets.formats.vamr:read": ("vamr:checkerboard", "vamr:/nowhere", ("frames", 0)),
    "slamarena.datasets.formats.carpark:read": ("carpark", "carpark:/nowhere", ("mount_heading", 1.0)),
}


def test_every_family_reader_declares_its_location_and_options_as_one_model():
    assert (
        {f.reader for f in catalogue.FORMATS.values()}
        == {e.reader for e in catalogue.CATALOGUE.values()}
        == set(READERS)
    )
    for target in READERS:
        model = params_model(import_target(target))
        assert (
            issubclass(model, SourceParams)
            and "path" in model.location
            and set(model.location) <= set(model.model_fields)
        )
        assert not {"files", "name"} & set(model.model_fields)  # the registry supplies them
    for target in SIMULATORS.values():
        model = params_model(import_target(target))
        assert model().seed == 0
        with pytest.raises(ValidationError, match="seed"):
            model(seed=-1)


def test_catalogue_presets_validate_through_the_readers_models():
    for entry in catalogue.CATALOGUE.values():
        resolved = catalogue.FORMATS[entry.family].params(entry.arguments).canonical()
        assert {k: resolved[k] for k in entry.arguments} == entry.arguments


@pytest.mark.parametrize("reader", sorted(READERS))
def test_unknown_and_bad_reader_options_are_rejected_naming_the_field(reader, monkeypatch, tmp_path):
    monkeypatch.setattr(
        dataroot, "data_roots", lambda existing_only=True: [tmp_path]
    )  # checked before any file is looked for
    name, at_path, bad = READERS[reader]
    assert_rejected_naming(functools.partial(datasets.load, name), bogus_option=1)
    for field, value in [("bogus_option", 1)] + ([bad] if bad else []):
        assert_rejected_naming(functools.partial(datasets.load, at_path), **{field: value})


@pytest.mark.parametrize(
    "name,typo",
    [
        ("victoria_park", {"varient": "isam"}),
        ("utias:6/robot1", {"directory": "/data"}),
        ("utias", {"path": "/data/MRCLAM_Dataset7", "robot": 1, "robt": 1}),
    ],
)
def test_misspelt_reader_keywords_are_errors_not_ignored(name, typo):
    with pytest.raises(ValidationError, match=list(typo)[-1]):
        datasets.load(name, **typo)


@pytest.mark.parametrize(
    "name,params,fragments",
    [
        (
            "utias:6/robot1",
            {"path": "/data/MRCLAM_Dataset7"},
            [
                "catalogued",
                "path cannot be given",
                "utias:<path>/robot<k>",
                "{name: utias, params: {path: …, robot: …}}",
            ],
        ),
        (
            "victoria_park",
            {"variant": "isam"},
            ["variant cannot be given", "Catalogued: victoria_park, victoria_park:isam"],
        ),
        ("carmen-corrected:aces", {"corrected": False}, ["corrected cannot be given"]),
        ("utias:/data/MRCLAM_Dataset7/robot1", {"robot": 2}, ["already sets robot"]),
        ("carmen-corrected:/data/x.log", {"corrected": False}, ["already sets corrected"]),
        ("utias:/data/MRCLAM_Dataset7", {}, ["expected utias:<path>/robot<k>"]),
    ],
)
def test_a_name_and_params_that_disagree_about_the_files_are_an_error(name, params, fragments):
    with pytest.raises(DatasetNameError) as err:
        datasets.load(name, **params)
    for fragment in fragments:
        assert fragment in str(err.value)


def test_an_unknown_recording_says_what_is_missing_and_how_to_name_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(DatasetNotFoundError) as err:
        datasets.load("utias:7/robot1")
    message = str(err.value)
    assert str(tmp_path / "7/Robot1_Odometry.dat") in message and "Catalogued: utias:1/robot1" in message
    assert "utias:<path>/robot<k> (e.g. utias:/data/MRCLAM_Dataset7/robot1)" in message
    with pytest.raises(KeyError, match="unknown dataset 'mrclam:7'.*<family>:<path>"):
        datasets.load("mrclam:7")


def _same(a, b) -> None:
    """Two loads of one recording hold the same data (their names and file paths aside)."""

    def content(x):
        summary = x.summary()
        summary.pop("name")
        for key in ("file", "files", "relations", "ground_truth"):  # paths
            summary["meta"].pop(key, None)
        return json.dumps(summary, sort_keys=True, default=lambda v: np.asarray(v).tolist())

    assert content(a) == content(b)


def _relative(dataset, files: dict) -> dict:
    """Role → the dataset's candidate path that each found file is (the wheel's copies: the first candidate)."""
    return {
        role: next((c for c in dataset.layout.files[role] if str(path).endswith(c)), dataset.layout.files[role][0])
        for role, path in files.items()
    }


@pytest.mark.parametrize(
    "entry,family",
    [
        ("utias:6/robot4", "utias"),
        ("victoria_park:isam", "victoria_park"),
        ("plaza:Plaza2", "plaza"),
        ("g2o:manhattan", "g2o"),
        ("g2o:w100", "toro"),
        ("isam:manhattanOlson3500", "isam"),
        ("carmen:aces", "carmen"),
        ("carmen-corrected:orebro", "carmen-corrected"),
    ],
)
def test_every_family_reads_a_recording_at_a_path_as_its_catalogued_copy(entry, family, tmp_path):
    """The catalogued files linked under another directory and named ``<family>:<path>`` (the other parameters as
    params) read as the catalogued dataset."""
    dataset = resolve(entry)
    try:
        files = dataset.files()
    except DatasetNotFoundError as missing:
        pytest.skip(f"{missing.relative} of {entry} is not staged")
    _link(files, tmp_path, _relative(dataset, files), files)
    p = dataset.params
    moved = p.model_copy(
        update={k: str(tmp_path / getattr(p, k)) for k in ("path", "ground_truth") if getattr(p, k, None)}
    )
    spelled = moved.spelled()
    params = {
        k: v
        for k, v in moved.model_dump().items()
        if k not in {*p.shorthand(spelled), *catalogue.FORMATS[family].fixed}
    }
    at_path = datasets.load(f"{family}:{spelled}", **params)
    assert at_path.name == f"{family}:{spelled}"
    _same(at_path, load_staged(entry))


def _link(files: dict, root, rel: dict, roles) -> None:
    for role in roles:
        (root / rel[role]).parent.mkdir(parents=True, exist_ok=True)
        (root / rel[role]).symlink_to(files[role])


@pytest.mark.realdata
def test_a_catalogued_dataset_is_read_from_the_first_root_holding_all_its_files(tmp_path, monkeypatch):
    """Root a lacks Dataset 6's ground truth of robot 1, root b holds everything: every file comes from b (before, the
    odometry came from a and the ground truth from b)."""
    dataset = resolve("utias:6/robot1")
    try:
        files = dataset.files()
    except DatasetNotFoundError:
        pytest.skip("utias:6/robot1 is not staged")
    rel = _relative(dataset, files)
    a, b = tmp_path / "a", tmp_path / "b"
    _link(files, a, rel, [r for r in files if r != "groundtruth"])
    _link(files, b, rel, files)
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [a, b])
    s = datasets.load("utias:6/robot1")
    assert s.ground_truth is not None and all(f.startswith(str(b)) for f in s.meta["files"]), s.meta["files"]
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [a])
    with pytest.raises(DatasetNotFoundError, match="Robot1_Groundtruth.dat"):
        datasets.load("utias:6/robot1")


def test_the_gtsam_wheel_is_one_root(tmp_path, monkeypatch):
    """A data root with Plaza2's odometry alone does not lend it to the wheel's copy of the other files."""
    pytest.importorskip("gtsam")
    wheel = dataroot.gtsam_example("plaza_range_only/Plaza2_DR.txt")
    (tmp_path / "plaza_range_only").mkdir()
    (tmp_path / "plaza_range_only/Plaza2_DR.txt").write_text("".join(wheel.read_text().splitlines(keepends=True)[:10]))
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [tmp_path])
    s = datasets.load("plaza:Plaza2")
    assert len(s.motion) == 4090 and all(not f.startswith(str(tmp_path)) for f in s.meta["files"])


def test_optional_files_come_only_with_the_required_ones(tmp_path, monkeypatch):
    """A recording named relative to the data roots: root a holds it without ground truth, root b with: a's is read,
    and b's ground truth is not joined to it."""
    from test_formats_mrclam import _recording

    _recording(tmp_path / "a/rec")
    _recording(tmp_path / "b/rec", truth=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [tmp_path / "a", tmp_path / "b"])
    s = datasets.load("utias:rec/robot2")
    assert s.ground_truth is None and all(f.startswith(str(tmp_path / "a")) for f in s.meta["files"])


@pytest.mark.realdata
def test_staged_datasets_are_present():
    if not any(
        (root / rel).exists() for root in dataroot.data_roots() for e in catalogue.CATALOGUE.values() for rel in e.files
    ):
        pytest.skip("no staged dataset file under any data root (a fresh clone: only the GTSAM wheel's data is here)")
    missing = [n for n in catalogue.CATALOGUE if not resolve(n).present()]
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
