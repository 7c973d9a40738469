"""CARMEN reader on the staged raw and corrected logs (values checked by hand with awk) and bad input."""

from __future__ import annotations

import bz2
import functools
import gzip
import re

import numpy as np
import pytest
from checks import assert_rejected_naming, load_staged, staged

from slamarena.datasets import DataFormatError, DataWarning, Increments
from slamarena.datasets.estimate import Estimate
from slamarena.datasets.formats import carmen
from slamarena.datasets.formats._text import read_bytes
from slamarena.datasets.geometry import accumulate

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
    assert (
        np.all(np.diff(intel.scans.t) > 0) and intel.meta["time_adjusted_messages"] > 0
    )  # strictly: one pose per stamp
    period = np.median(np.diff(raw)[np.diff(raw) > 0])
    assert np.all(intel.scans.t >= raw) and np.max(intel.scans.t - raw) < carmen.JITTER_S + period


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
    assert (
        len(s.scans) == 2 and s.meta["dropped_scans_other_layout"] == 1
    )  # 3 beams at 90°: another step, not interlaced
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


def test_corrected_intel_on_odometry():
    """odometry_scan_pose: each scan carries the last raw ODOM pose before it (lines 175 and 185 of the file, by awk),
    the corrected poses stay the ground truth; a raw log has no such option."""
    s = load_staged("carmen-corrected:intel", odometry_scan_pose=True)
    assert np.allclose(s.scans.pose[:2], [[0.698035, -0.0132843, -0.460915], [0.60258, -0.034798, -0.920053]])
    assert np.allclose(s.ground_truth.poses[0], [0.600266, -0.0320327, -0.354665])
    assert np.allclose(accumulate(s.scans.pose[0], s.motion.delta), s.scans.pose, atol=1e-9)
    with pytest.raises(ValueError, match="odometry_scan_pose applies to a corrected log"):
        carmen.CarmenParams(odometry_scan_pose=True)


@pytest.mark.parametrize(
    "name, scans, beams, time_source",
    [
        ("freiburg-campus", 2008, 360, "scan index"),
        ("orebro", 237, 181, "scan index"),
        ("acapulco", 861, 181, "ipc"),
        ("seattle", 241, 361, "ipc"),
        ("csail", 406, 361, "scan index"),  # 406 scans, 2 distinct stamps: the reader once spread them over 19756 s
    ],
)
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
    assert carmen.read.Params is carmen.CarmenParams and issubclass(carmen.load.Params, carmen.CarmenParams)
    assert (
        given.scans.max_range == keywords.scans.max_range == 2.5
        and given.meta["no_return_readings"] == keywords.meta["no_return_readings"] == 4
    )
    np.testing.assert_array_equal(given.scans.ranges, keywords.scans.ranges)
    assert carmen.load({"log": path}, "small", path=str(path), max_range=2.5).meta["no_return_readings"] == 4


@pytest.mark.parametrize("bad", [dict(max_range=0.0), dict(beams=0), dict(interlaced="maybe"), dict(max_rang=4.0)])
def test_bad_or_unknown_options_name_the_field(tmp_path, bad):
    assert_rejected_naming(functools.partial(carmen.read, _log(tmp_path, GOOD)), **bad)


def _steady_log(n: int = 20) -> list[str]:
    """n ODOM and n FLASER messages at 5 Hz (ODOM k at 100 + 0.2 k s, its scan 0.1 s later), 0.1 m forward per step:
    line 1 is a comment, ODOM k is on line 2k + 2 and its FLASER on line 2k + 3."""
    lines = ["# a steady 5 Hz log"]
    for k in range(n):
        t, x = 100 + 0.2 * k, 0.1 * k
        lines += [
            f"ODOM {x:.1f} 0 0 0 0 0 {t:.1f} host 0",
            f"FLASER 4 1 2 3 4 {x:.1f} 0 0 {x:.1f} 0 0 {t + 0.1:.1f} host 0",
        ]
    return lines


def _shift_stamp(line: str, seconds: float) -> str:
    tag, *fields = line.split()
    fields[-3] = f"{float(fields[-3]) + seconds:.1f}"
    return " ".join([tag, *fields])


@pytest.mark.parametrize(
    "line, shift", [(6, 50.0), (6, -50.0), (7, 50.0), (7, -50.0), (2, 50.0), (41, -50.0), (8, -100.5)]
)
def test_one_stamp_out_of_order_drops_its_message_not_the_time_base(tmp_path, line, shift):
    lines = _steady_log()
    lines[line - 1] = _shift_stamp(lines[line - 1], shift)
    path = _log(tmp_path, "\n".join(lines) + "\n")
    with pytest.warns(DataWarning, match=re.escape(f"{path}:{line}: 1 message(s) dropped")):
        s = carmen.read(path)
    assert s.meta["dropped_lines"] == {"binary_garbage": [], "out_of_range": [], "bad_timestamp": [line]}
    assert s.meta["time_source"].startswith("ipc_timestamp") and s.meta["time_adjusted_messages"] == 0
    assert 4.7 < s.summary()["scans"]["rate_hz"] < 5.3  # the log's own 5 Hz, not the scan index's 1 Hz
    scan_lines = 2 * np.arange(20) + 3
    assert len(s.scans) == 20 - (line in scan_lines) and np.all(np.diff(s.scans.t) > 0.15)
    assert len(s.motion) == 19 - (line not in scan_lines)
    np.testing.assert_allclose(
        accumulate(s.initial_pose, s.motion.delta)[-1], [1.9, 0, 0], atol=1e-12
    )  # the neighbours carry the motion


@pytest.mark.parametrize(
    "garbage",
    [
        b"#\xd61$\xd4V\xe1\x99\x9f\xd81\xc3",
        b"E\t\x06E\x89\x9c\xa7\x99\xe5",
        b"\x00" * 60,
        b"\x85\xa0\x1c\x1d",
        b"FLASER 4 1 2 3 4 0.2 0 0 0.2 0 0 \x00\x00\x00\x00 host 0",
    ],
)
def test_a_line_of_binary_garbage_is_dropped_counted_and_warned(tmp_path, garbage):
    lines = [line.encode() for line in _steady_log()]
    lines[6] = garbage  # line 7, the FLASER of step 2
    path = tmp_path / "log.clf"
    path.write_bytes(b"\n".join(lines) + b"\n")
    with pytest.warns(DataWarning, match=re.escape(f"{path}:7: 1 message(s) dropped, holding binary garbage")):
        s = carmen.read(path)
    assert s.meta["dropped_lines"] == {"binary_garbage": [7], "out_of_range": [], "bad_timestamp": []}
    assert s.meta["ignored_messages"] == {} and len(s.scans) == 19 and s.meta["time_source"].startswith("ipc_timestamp")


@pytest.mark.parametrize("zeros, time_source", [(9, "ipc_timestamp"), (11, "scan index")])
def test_only_a_log_whose_stamps_mostly_carry_no_time_goes_by_the_scan_index(tmp_path, zeros, time_source):
    lines = _steady_log()
    for k in range(zeros):  # ODOM stamps 0 (as corrected logs have them)
        lines[2 * k + 1] = _shift_stamp(lines[2 * k + 1], -(100 + 0.2 * k))
    with pytest.warns(DataWarning) as caught:
        s = carmen.read(_log(tmp_path, "\n".join(lines) + "\n"))
    assert s.meta["time_source"].startswith(time_source)
    if zeros < 10:
        assert (
            s.meta["dropped_lines"]["bad_timestamp"] == [2 * k + 2 for k in range(zeros)]
            and len(s.motion) == 20 - zeros - 1
        )
    else:
        assert (
            "carry no time" in str(caught[0].message)
            and len(s.motion) == 19
            and s.meta["dropped_lines"]["bad_timestamp"] == []
        )


def test_a_log_whose_stamps_repeat_a_few_values_goes_by_the_scan_index(tmp_path):
    """Stamps on their clock but mostly alike (two distinct values, as the corrected CSAIL log's) carry no time: the
    running maximum would spread them over the log instead."""
    lines = _steady_log()
    for k in range(20):  # every ODOM and FLASER stamped 100 s or 200 s, never stepping back
        lines[2 * k + 1] = _shift_stamp(lines[2 * k + 1], (100.0 if k < 10 else 200.0) - (100 + 0.2 * k))
        lines[2 * k + 2] = _shift_stamp(lines[2 * k + 2], (100.0 if k < 10 else 200.0) - (100 + 0.2 * k + 0.1))
    with pytest.warns(DataWarning, match="carry no time"):
        s = carmen.read(_log(tmp_path, "\n".join(lines) + "\n"))
    assert s.meta["time_source"].startswith("scan index") and np.array_equal(s.scans.t, np.arange(20.0))


def test_staged_intel_with_a_late_odom_and_a_garbage_scan_keeps_its_clock(intel, tmp_path):
    lines = read_bytes(staged("radish_laser_logs/intel.clf.bz2")).split(b"\n")
    odom = [k for k, line in enumerate(lines) if line.startswith(b"ODOM ")][10000]
    scan = [k for k, line in enumerate(lines) if line.startswith(b"FLASER ")]
    lost = 5000
    lines[odom] = _shift_stamp(lines[odom].decode(), 50.0).encode()
    lines[scan[lost]] = bytes(range(256))[::3]
    path = tmp_path / "intel.clf"
    path.write_bytes(b"\n".join(lines))
    with pytest.warns(DataWarning):
        s = carmen.read(path, max_range=80.0)
    assert s.meta["dropped_lines"] == {
        "binary_garbage": [scan[lost] + 1],
        "out_of_range": [],
        "bad_timestamp": [odom + 1],
    }
    assert s.meta["time_source"] == intel.meta["time_source"]
    np.testing.assert_array_equal(s.meta["scan_ipc_timestamp"], np.delete(intel.meta["scan_ipc_timestamp"], lost))
    assert len(s.motion) == len(intel.motion) - 1
    np.testing.assert_allclose(
        accumulate(s.initial_pose, s.motion.delta)[-1],
        accumulate(intel.initial_pose, intel.motion.delta)[-1],
        atol=1e-9,
    )
    assert s.summary()["scans"]["rate_hz"] == pytest.approx(intel.summary()["scans"]["rate_hz"], rel=1e-3)


def test_a_staged_relations_file_comes_with_its_log_and_the_metric_uses_it(tmp_path):
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file

    relations = staged("radish_laser_logs/relations/mit-csail.relations")
    seq = load_staged("carmen:mit-csail")
    assert seq.meta["relations"] == str(relations)
    est = Estimate("scan poses", seq.scans.t, seq.scans.pose)
    scores, _ = relation_error_from_file(est, seq, RelationsParams())  # no file named: the dataset's
    assert scores["used"] == 1172
    mine = tmp_path / "mine.relations"
    mine.write_text(relations.read_text().splitlines()[0] + "\n")
    assert load_staged("carmen:mit-csail", relations=mine).meta["relations"] == str(mine)
    assert "relations" not in load_staged("carmen:aces").meta


def test_clamped_stamps_are_spread_to_increase_strictly():
    t = carmen.strictly_increasing([0.0, 1.0, 1.0, 1.0, 2.0, 1.5, 3.0, 3.0, 9.0])
    np.testing.assert_allclose(
        t, [0.0, 1.0, 4 / 3, 5 / 3, 2.0, 2.5, 3.0, 3.5, 9.0]
    )  # at most one median step (1 s) per run
    assert np.all(np.diff(t) > 0)
    np.testing.assert_array_equal(carmen.strictly_increasing([0.0, 0.2, 0.4]), [0.0, 0.2, 0.4])  # nothing to do


@pytest.mark.parametrize(
    "line, field, value, why",
    [
        (6, 1, "1e300", "ODOM x outside"),  # ODOM x
        (6, 3, "-1e5", "ODOM theta outside"),
        (7, 2, "-5", "a reading outside [0, 1000] m"),  # FLASER's first reading
        (7, 6, "1e300", "scan pose x outside"),
    ],
)
def test_a_value_outside_its_physical_range_drops_its_message(tmp_path, line, field, value, why):
    """An ODOM x of 1e300 m, a reading of −5 m: the message is dropped, counted with its line and warned about; its
    neighbours carry the motion across (dead reckoning ends where the clean log's does)."""
    lines = _steady_log()
    parts = lines[line - 1].split()
    parts[field] = value
    lines[line - 1] = " ".join(parts)
    path = _log(tmp_path, "\n".join(lines) + "\n")
    with pytest.warns(DataWarning, match=re.escape(f"{path}:{line}: 1 message(s) dropped") + ".*" + re.escape(why)):
        s = carmen.read(path)
    assert s.meta["dropped_lines"]["out_of_range"] == [line]
    assert len(s.scans) == 20 - (line == 7) and len(s.motion) == 19 - (line == 6)
    assert np.nanmin(s.scans.ranges) >= 0 and s.scans.max_range == 4
    np.testing.assert_allclose(accumulate(s.initial_pose, s.motion.delta)[-1], [1.9, 0, 0], atol=1e-12)
