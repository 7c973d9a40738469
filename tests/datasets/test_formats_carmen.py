"""CARMEN reader on the staged raw and corrected logs (values checked by hand with awk) and bad input."""
from __future__ import annotations

import bz2
import functools
import gzip

import numpy as np
import pytest

from slamarena.datasets import DataFormatError, Increments
from slamarena.datasets.formats import carmen
from slamarena.datasets.geometry import accumulate
from checks import assert_rejected_naming, load_staged

pytestmark = pytest.mark.realdata


@pytest.fixture(scope="module")
def intel():
    return load_staged("carmen:intel")


def test_intel_counts_and_first_last_scan(intel):
    sc = intel.scans
    assert len(sc) == 13631 and sc.ranges.shape == (13631, 180) and sc.ranges.dtype == np.float32
    assert np.allclose(sc.ranges[0, :3], [1.07, 1.07, 1.08]) and np.isclose(sc.ranges[-1, 0], 1.00)
    assert np.isclose(sc.ranges[-1, -1], 1.12)
    assert np.allclose(sc.pose[0], [0, 0, -0.002458]) and np.allclose(sc.pose[-1], [-50.883999, -35.825001, 2.538102])
    assert sc.t[0] == 976052857.337530 and intel.meta["scan_ipc_timestamp"][-1] == 976055548.624744
    assert np.allclose(sc.angles[[0, 1, -1]], np.radians([-90, -89, 89]))
    assert np.allclose(sc.mount, 0) and sc.max_range == 80.0
    assert intel.meta["no_return_readings"] == int((sc.ranges >= 80).sum()) > 0


def test_intel_odometry_increments_reproduce_odom_poses(intel):
    m = intel.motion
    assert isinstance(m, Increments) and len(m) == 26914  # 26915 ODOM lines
    poses = accumulate(intel.initial_pose, m.delta)
    assert np.allclose(poses[-1], [-50.883999, -35.825001, 2.538102], atol=1e-6)


def test_intel_time_jitter_is_clamped_and_original_stamps_kept(intel):
    # the Intel log's ipc stamps step back by up to 0.9 s (631 scans): file order is the true order
    raw = intel.meta["scan_ipc_timestamp"]
    assert (np.diff(raw) < 0).sum() == 631
    assert np.all(np.diff(intel.scans.t) >= 0) and intel.meta["time_adjusted_messages"] > 0
    assert np.all(intel.scans.t >= raw) and np.max(intel.scans.t - raw) < carmen.JITTER_S


def test_strict_time_rejects_stamps_going_back(tmp_path):
    text = GOOD.replace("1.3 host", "1.05 host")
    with pytest.raises(DataFormatError, match="non-decreasing time") as err:
        carmen.read(_log(tmp_path, text), strict_time=True)
    assert err.value.line == 5
    assert carmen.read(_log(tmp_path, text)).meta["time_adjusted_messages"] == 1


def test_fr079_mount_offset_and_half_degree_beams():
    s = load_staged("carmen:fr079")
    assert len(s.scans) == 4934 and s.scans.ranges.shape[1] == 360
    assert np.allclose(s.scans.mount, [-0.04, 0.0, 0.0], atol=1e-3)  # PARAM robot_frontlaser_offset -0.04
    assert np.isclose(np.diff(s.scans.angles)[0], np.radians(0.5))
    assert s.meta["params"]["robot_frontlaser_offset"] == "-0.04"


def test_mit_csail_without_odom_uses_scan_odometry():
    s = load_staged("carmen:mit-csail")
    assert len(s.scans) == 1988 and s.scans.ranges.shape[1] == 361
    assert np.allclose(s.scans.angles[[0, 180, 360]], [-np.pi / 2, 0, np.pi / 2])
    assert len(s.motion) == 1987 and "no ODOM" in s.meta["motion_source"]
    assert np.allclose(s.scans.pose[0], [576.536523, 0.106594, -2.255213])


def test_beam_layout_selection(tmp_path):
    text = GOOD + "FLASER 3 1 2 3 2 0 0 2 0 0 1.4 host 0\n"
    s = carmen.read(_log(tmp_path, text))
    assert len(s.scans) == 2 and s.meta["dropped_scans_other_layout"] == 1  # 3 beams at 90°: another step, not interlaced
    assert not s.meta["interlaced"] and s.scans.angle_offset is None and s.scans.beam_count is None
    s3 = carmen.read(_log(tmp_path, text), beams=3)
    assert len(s3.scans) == 1 and np.allclose(s3.scans.angles, [-np.pi / 2, 0, np.pi / 2])


def test_corrected_intel():
    s = load_staged("carmen-corrected:intel")
    assert len(s.scans) == 910 and s.meta["ground_truth_kind"] == "slam-reference"
    assert s.meta["skipped_echo_odom"] == 910 == s.meta["echo_odom_matching_scan_pose"]
    assert np.allclose(s.scans.pose[0], [0.600266, -0.0320327, -0.354665])
    assert np.allclose(s.ground_truth.poses[-1], [-0.596494, -0.101202, 0.0119294])
    assert s.scans.t[0] == 32.9068 and s.scans.t[-1] == 2683.77
    assert np.isclose(s.scans.ranges[-1, 0], 1.01) and len(s.motion) == 909


@pytest.mark.parametrize("name, scans, beams, time_source", [
    ("freiburg-campus", 2008, 360, "scan index"), ("orebro", 237, 181, "scan index"),
    ("acapulco", 861, 181, "ipc"), ("seattle", 241, 361, "ipc"),
])
def test_corrected_logs_with_bad_stamps(name, scans, beams, time_source):
    s = load_staged(f"carmen-corrected:{name}")
    assert s.scans.ranges.shape == (scans, beams) and s.meta["time_source"].startswith(time_source)
    assert len(s.motion) == scans - 1 and s.meta["skipped_echo_odom"] == scans


def _log(tmp_path, text, suffix=".clf"):
    path = tmp_path / f"log{suffix}"
    if suffix.endswith(".gz"):
        with gzip.open(path, "wt") as f:
            f.write(text)
    elif suffix.endswith(".bz2"):
        with bz2.open(path, "wt") as f:
            f.write(text)
    else:
        path.write_text(text)
    return path


GOOD = (
    "# comment\n"
    "ODOM 0 0 0 0 0 0 1.0 host 0\n"
    "FLASER 4 1 2 3 4 0 0 0 0 0 0 1.1 host 0\n"
    "ODOM 1 0 0 0 0 0 1.2 host 0\n"
    "FLASER 4 1 2 3 4 1 0 0 1 0 0 1.3 host 0\n"
)


@pytest.mark.parametrize("suffix", [".clf", ".log.gz", ".clf.bz2"])
def test_small_log_all_compressions(tmp_path, suffix):
    s = carmen.read(_log(tmp_path, GOOD, suffix), max_range=4.0)
    assert s.scans.ranges.shape == (2, 4) and np.allclose(s.scans.angles, np.radians([-90, -45, 0, 45]))
    assert s.meta["no_return_readings"] == 2 and np.allclose(s.motion.delta, [[1, 0, 0]])


@pytest.mark.parametrize(
    "line, fragment",
    [
        ("FLASER 4 1 2 3 0 0 0 0 0 0 1.15 host 0", "FLASER n r_1"),  # one reading missing
        ("FLASER 4 1 2 x 4 0 0 0 0 0 0 1.15 host 0", "numeric"),
        ("ODOM 0 0 0 0 0 1.15 host 0", "7 numeric fields"),
        ("12 FLASER 4", "message name"),
    ],
)
def test_malformed_log_line(tmp_path, line, fragment):
    lines = GOOD.splitlines()
    lines.insert(3, line)  # becomes line 4
    path = _log(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(DataFormatError) as err:
        carmen.read(path)
    assert err.value.line == 4 and str(path) in str(err.value) and fragment in str(err.value)


def test_truncated_compressed_file_is_a_format_error(tmp_path):
    path = _log(tmp_path, GOOD * 50, ".clf.bz2")
    path.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(DataFormatError, match="bz2"):
        carmen.read(path)


def test_a_params_model_and_keywords_read_alike(tmp_path):
    path = _log(tmp_path, GOOD)
    given = carmen.read(path, params=carmen.CarmenParams(max_range=2.5, strict_time=True))
    keywords = carmen.read(path, max_range=2.5, strict_time=True)
    assert carmen.read.Params is carmen.load.Params is carmen.CarmenParams
    assert given.scans.max_range == keywords.scans.max_range == 2.5 and given.meta["no_return_readings"] == keywords.meta["no_return_readings"] == 4
    np.testing.assert_array_equal(given.scans.ranges, keywords.scans.ranges)
    assert carmen.load({"log": path}, "small", max_range=2.5).meta["no_return_readings"] == 4


@pytest.mark.parametrize("bad", [dict(max_range=0.0), dict(beams=0), dict(interlaced="maybe"), dict(max_rang=4.0)])
def test_bad_or_unknown_options_name_the_field(tmp_path, bad):
    assert_rejected_naming(functools.partial(carmen.read, _log(tmp_path, GOOD)), **bad)
