"""Data roots: the search order, the GTSAM wheel's example data as the last root, and a fresh clone's test run."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from slamarena.datasets import DatasetNotFoundError, catalogue, dataroot, load
from slamarena.datasets.formats._text import read_bytes

ROOT = Path(__file__).resolve().parents[2]


def test_every_wheel_alias_is_a_catalogued_file_the_wheel_ships():
    pytest.importorskip("gtsam")
    catalogued = {rel for entry in catalogue.CATALOGUE.values() for rel in entry.files}
    assert set(dataroot.GTSAM_WHEEL) <= catalogued
    for rel, name in dataroot.GTSAM_WHEEL.items():
        path = dataroot.gtsam_example(rel)
        assert path is not None and path.name == name and path.is_file(), rel
    assert dataroot.gtsam_example("sesync_g2o/intel.g2o") is None


@pytest.mark.realdata
def test_the_wheel_copies_are_the_staged_files():
    pytest.importorskip("gtsam")
    compared = 0
    for rel in dataroot.GTSAM_WHEEL:
        staged = [root / rel for root in dataroot.data_roots() if (root / rel).exists()]
        if staged:
            assert read_bytes(staged[0]) == read_bytes(dataroot.gtsam_example(rel)), rel
            compared += 1
    if not compared:
        pytest.skip("no staged copy of the wheel's files under any data root")


def test_the_data_roots_come_before_the_wheel(monkeypatch, tmp_path):
    pytest.importorskip("gtsam")
    rel = "gtsam_examples_data/noisyToyGraph.txt"
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [tmp_path])
    assert dataroot.locate(rel) == dataroot.gtsam_example(rel)
    (tmp_path / rel).parent.mkdir(parents=True)
    (tmp_path / rel).write_text("VERTEX_SE2 0 0 0 0\n")
    assert dataroot.locate(rel) == tmp_path / rel
    assert dataroot.locate("sesync_g2o/intel.g2o") is None
    with pytest.raises(DatasetNotFoundError, match="g2o:intel"):
        load("g2o:intel")


def test_without_gtsam_the_wheel_holds_nothing(monkeypatch):
    monkeypatch.setitem(sys.modules, "gtsam", None)  # import gtsam raises ImportError
    assert dataroot.gtsam_example("gtsam_examples_data/noisyToyGraph.txt") is None


#: a fresh clone's view (test → outcome): catalogue loads, ``staged`` files and the catalogue check skip when the file is
#: not staged; the GTSAM wheel's data (g2o:noisyToyGraph, plaza:Plaza2, Victoria Park's gtsam copy) runs
FRESH_CLONE = {
    "tests/datasets/test_formats_graphs.py::test_noisy_toy_graph_contents": "PASSED",
    "tests/datasets/test_formats_graphs.py::test_intel_g2o_first_records": "SKIPPED",
    "tests/datasets/test_formats_plaza.py::test_plaza2_first_and_last_rows": "PASSED",
    "tests/datasets/test_formats_victoria_park.py::test_counts_first_records_and_time_is_pose_index[gtsam]": "PASSED",
    "tests/datasets/test_formats_victoria_park.py::test_counts_first_records_and_time_is_pose_index[isam]": "SKIPPED",
    "tests/datasets/test_formats_catalogue.py::test_staged_datasets_are_present": "SKIPPED",
}


def test_a_fresh_clone_skips_what_is_not_staged_and_runs_the_wheels_data(tmp_path):
    """The README's test command on a clone without ``../shared/datasets`` (``SLAMARENA_SEARCH_SHARED=0``, an empty
    download cache), on a few tests standing for the three ways a test reads real data: nothing fails, what is not
    staged skips naming the file, the wheel's data runs. (The whole suite this way: README, "Run the tests".)"""
    pytest.importorskip("gtsam")
    env = {
        **os.environ,
        "SLAMARENA_SEARCH_SHARED": "0",
        "SLAMARENA_CACHE": str(tmp_path / "cache"),
        "PYTHONPATH": str(ROOT),
    }
    env.pop("SLAMARENA_DATA", None)
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-v", "-rs", "-p", "no:cacheprovider", *FRESH_CLONE],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stdout[-3000:]
    outcome = {
        line.split()[0]: line.split()[1]
        for line in run.stdout.splitlines()
        if line.startswith("tests/") and "::" in line
    }
    assert outcome == FRESH_CLONE, run.stdout[-3000:]
    assert "dataset file sesync_g2o/intel.g2o of g2o:intel is not under any data root" in " ".join(run.stdout.split())
