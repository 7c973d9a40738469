"""`slamarena data fetch`: pinned URLs and sha256, tested offline with pooch's downloader replaced."""

from __future__ import annotations

import gzip
import hashlib
import re
from pathlib import Path

import numpy as np
import pytest
from checks import staged

from slamarena.datasets import catalogue, dataroot, fetch, load
from slamarena.datasets.formats import isam
from slamarena.datasets.formats._text import read_bytes


def _upstream(rel: str) -> bytes:
    """The upstream content of a staged file: decompressed where the stager compressed it (by the file's own suffix:
    the GTSAM wheel's copy of a staged ``.gz`` is plain)."""
    path = staged(rel)
    return read_bytes(path) if fetch.FILES[rel][2] else path.read_bytes()


def _serve_staged(url: str, output_file, pooch_obj=None):
    """A pooch downloader that copies the staged file's upstream content."""
    rel = next(r for r, (up, _, _) in fetch.FILES.items() if url.endswith(up))
    Path(output_file).write_bytes(_upstream(rel))


@pytest.fixture
def offline(tmp_path, monkeypatch):
    monkeypatch.setenv("SLAMARENA_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(fetch, "_downloader", lambda: _serve_staged)
    return tmp_path / "cache"


def test_every_catalogue_file_is_pinned_to_a_commit():
    for entry in catalogue.CATALOGUE.values():
        if not entry.fetchable:  # staged-only camera sequences: fetch refuses them by name
            with pytest.raises(fetch.FetchError, match="staged only"):
                fetch.fetch(entry.name, force=True)
            continue
        layout = entry.layout()
        for role, candidates in layout.files.items():
            pinned = [rel for rel in candidates if rel in fetch.FILES]
            assert len(pinned) == 1 or not pinned and role in layout.optional, (entry.name, role)
            if not pinned:
                continue
            upstream, sha, _ = fetch.FILES[pinned[0]]
            assert re.fullmatch(r"[0-9a-f]{64}", sha)
            assert re.match(r"https://raw\.githubusercontent\.com/[^/]+/[^/]+/[0-9a-f]{40}/", fetch.url_of(pinned[0]))
    assert "/curow/multi-robot-localization/adf9111354153f5bf3fc55ecc0c348c222241f37/MRCLAM/" in fetch.url_of(
        "utias_mrclam/MRCLAM_Dataset6/Robot1_Odometry.dat.gz"
    )


@pytest.mark.realdata
def test_pinned_hashes_match_the_staged_upstream_content():
    for rel, (_, sha, _) in fetch.FILES.items():
        assert hashlib.sha256(_upstream(rel)).hexdigest() == sha, rel


@pytest.mark.realdata
def test_fetch_plain_file(offline):
    paths = fetch.fetch("g2o:noisyToyGraph", force=True)
    assert paths == [offline / "gtsam_examples_data/noisyToyGraph.txt"]
    assert paths[0].read_bytes() == staged("gtsam_examples_data/noisyToyGraph.txt").read_bytes()
    assert not list((offline / ".downloads").rglob("*.txt"))  # the staging copy is removed


@pytest.mark.realdata
def test_fetch_recompresses_into_the_catalogue_layout(offline):
    (path,) = fetch.fetch("isam:w20000", force=True)
    assert path == offline / "gtsam_examples_data/w20000.txt.gz"
    assert gzip.decompress(path.read_bytes()) == _upstream("gtsam_examples_data/w20000.txt.gz")
    assert np.array_equal(isam.read(path).edge_z, load("isam:w20000").edge_z)


@pytest.mark.realdata
def test_fetch_rejects_a_bad_hash_and_stores_nothing(offline, monkeypatch):
    def corrupt(url, output_file, pooch_obj=None):
        _serve_staged(url, output_file, pooch_obj)
        Path(output_file).write_bytes(Path(output_file).read_bytes() + b"\n")

    monkeypatch.setattr(fetch, "_downloader", lambda: corrupt)
    with pytest.raises(fetch.FetchError, match="sha256"):
        fetch.fetch("g2o:noisyToyGraph", force=True)
    assert not (offline / "gtsam_examples_data/noisyToyGraph.txt").exists()


def test_fetch_skips_files_already_under_a_data_root(offline, monkeypatch):
    monkeypatch.setattr(fetch, "_downloader", lambda: pytest.fail("no download expected"))
    staged("gtsam_examples_data/pose2example.txt")
    assert fetch.fetch("g2o:pose2example")[0].exists()


@pytest.mark.realdata
def test_fetch_puts_every_file_in_the_cache_when_no_root_holds_them_all(offline, monkeypatch, tmp_path):
    """A data root with one of Dataset 1's files: all four of robot 1 go to the cache (one root), which then reads them."""
    upstream = {
        up: _upstream(rel) for rel, (up, _, _) in fetch.FILES.items() if rel.startswith("utias_mrclam/MRCLAM_Dataset1/")
    }
    monkeypatch.setattr(
        fetch,
        "_downloader",
        lambda: (
            lambda url, output_file, pooch_obj=None: Path(output_file).write_bytes(
                next(content for up, content in upstream.items() if url.endswith(up))
            )
        ),
    )
    partial = tmp_path / "partial"
    (partial / "utias_mrclam/MRCLAM_Dataset1").mkdir(parents=True)
    (partial / "utias_mrclam/MRCLAM_Dataset1/Barcodes.dat").write_bytes(
        staged("utias_mrclam/MRCLAM_Dataset1/Barcodes.dat").read_bytes()
    )
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [partial, offline])
    paths = fetch.fetch("utias:1/robot1")
    assert sorted(p.name for p in paths) == [
        "Barcodes.dat",
        "Landmark_Groundtruth.dat",
        "Robot1_Measurement.dat.gz",
        "Robot1_Odometry.dat.gz",
    ]
    assert all(p.is_relative_to(offline) for p in paths)
    assert all(f.startswith(str(offline)) for f in load("utias:1/robot1").meta["files"])


def test_unknown_name():
    with pytest.raises(KeyError, match="unknown dataset"):
        fetch.fetch("nope:1")
    with pytest.raises(fetch.FetchError, match="only a catalogued dataset"):
        fetch.fetch("g2o:/data/mine.g2o")
