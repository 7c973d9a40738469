"""UTIAS MRCLAM reader on the staged Datasets 1 and 6 (values checked by hand against the files)."""

from __future__ import annotations

import gzip

import numpy as np
import pytest
from checks import load_staged

from slamarena.datasets import DataFormatError, load
from slamarena.datasets.errors import DataWarning
from slamarena.estimators.dead_reckoning import DeadReckoning

pytestmark = pytest.mark.realdata


@pytest.fixture(scope="module")
def d6r1():
    return load_staged("utias:6/robot1")


def test_dataset6_robot1_odometry_first_and_last(d6r1):
    m = d6r1.motion
    assert len(m) == 61785  # SOURCE.md row count; no repeated stamps in this file
    assert m.t[0] == 1248444187.156 and m.v[0] == 0.086 and m.omega[0] == -0.398
    assert m.t[-1] == 1248445075.103 and m.v[-1] == 0.0 and m.omega[-1] == 0.0
    assert np.isclose(m.dt[0], 1248444187.186 - 1248444187.156)


def test_dataset6_robot1_measurements_mapped_through_barcodes(d6r1):
    rb, meta = d6r1.range_bearing, d6r1.meta
    # 1942 rows = 1534 landmark observations + 407 of other robots + 1 misread (barcode 43)
    assert meta["measurement_rows"] == 1942
    assert len(rb) == meta["landmark_observations"] == 1534
    assert meta["dropped_robot_observations"] == 407
    assert meta["dropped_misread_barcodes"] == 1 and meta["misread_barcodes"] == [43]
    # first row: barcode 14 = subject 2 (a robot) -> dropped; second: barcode 90 = subject 15
    assert rb.t[0] == 1248444189.599 and rb.landmark_id[0] == 15
    assert rb.range[0] == 6.758 and rb.bearing[0] == -0.005
    # last row: barcode 9 = subject 18
    assert rb.t[-1] == 1248444927.166 and rb.landmark_id[-1] == 18 and rb.range[-1] == 1.110 and rb.bearing[-1] == 0.469
    assert set(np.unique(rb.landmark_id)) <= set(range(6, 21))


def test_dataset6_robot1_ground_truth_and_landmarks(d6r1):
    gt = d6r1.ground_truth
    assert len(gt) == 49241
    assert gt.t[0] == 1248444175.103 and np.allclose(gt.poses[0], [1.41277290, -3.89107760, 2.26960000])
    assert gt.t[-1] == 1248444946.976 and np.allclose(gt.poses[-1], [3.77380520, 2.97411890, 0.43450000])
    lm = d6r1.landmarks
    assert lm.ids.tolist() == list(range(6, 21))
    assert np.allclose(lm.position(6), [0.58831396, -4.28264845]) and np.allclose(lm.std[0], [0.00004570, 0.00027395])
    # initial pose: ground truth interpolated at the first odometry stamp (robot static before it)
    assert np.allclose(d6r1.initial_pose[:2], gt.poses[0, :2], atol=0.01)


def test_dataset1_has_no_robot_ground_truth_and_counts_drops():
    s = load_staged("utias:1/robot3")
    assert s.ground_truth is None and s.initial_pose is None
    assert s.meta["measurement_rows"] == 8742
    assert (
        s.meta["landmark_observations"],
        s.meta["dropped_robot_observations"],
        s.meta["dropped_misread_barcodes"],
    ) == (6771, 1969, 2)
    # Dataset 1 maps barcodes differently from Dataset 6 (6 -> 72 there)
    assert len(s.landmarks) == 15


def _write(path, header_lines, rows):
    path.write_text("\n".join(["# header"] * header_lines + rows) + "\n")


def _recording(directory, truth=False):
    """Robot 2 of a small recording in the MRCLAM layout (one file compressed), with or without its ground truth."""
    directory.mkdir(parents=True, exist_ok=True)
    _write(directory / "Barcodes.dat", 4, ["1 5", "2 14", "6 63", "7 81"])
    _write(directory / "Landmark_Groundtruth.dat", 4, ["6 1.0 2.0 0.01 0.02", "7 3.0 4.0 0.01 0.02"])
    _write(directory / "Robot2_Odometry.dat", 4, ["10.0 0.1 0.0", "10.0 0.2 0.0", "10.5 0.3 0.1", "11.0 0.0 0.0"])
    with gzip.open(directory / "Robot2_Measurement.dat.gz", "wt") as f:
        f.write("# h\n10.2 63 1.5 0.1\n10.2 5 2.0 0.0\n10.7 99 1.0 0.0\n10.9 81 2.5 -0.2\n")
    if truth:
        _write(directory / "Robot2_Groundtruth.dat", 4, ["9.0 0.0 0.0 0.0", "12.0 1.0 0.0 0.0"])


def test_any_directory_in_the_format_and_repeated_stamps(tmp_path):
    _recording(tmp_path)
    s = load(f"utias:{tmp_path}/robot2")
    assert s.name == f"utias:{tmp_path}/robot2" and s.range_bearing.landmark_id.tolist() == [6, 7]
    assert s.meta["dropped_robot_observations"] == 1 and s.meta["misread_barcodes"] == [99]
    assert s.meta["odometry_zero_length_commands"] == 1 and len(s.motion) == 3
    assert s.ground_truth is None and s.initial_pose is None and s.meta["ground_truth_kind"].startswith("none")


def test_a_recording_by_name_by_params_and_relative_to_the_working_directory(tmp_path, monkeypatch):
    directory = tmp_path / "MRCLAM_Dataset7"
    _recording(directory, truth=True)
    by_name = load(f"utias:{directory}/robot2")
    by_params = load("utias", path=str(directory), robot=2)
    monkeypatch.chdir(tmp_path)
    relative = load("utias:MRCLAM_Dataset7/robot2")
    assert by_params.name == by_name.name
    assert by_name.ground_truth is not None and np.allclose(by_name.initial_pose, [1 / 3, 0, 0])
    for s in (by_params, relative):
        np.testing.assert_array_equal(s.motion.t, by_name.motion.t)
        np.testing.assert_array_equal(s.range_bearing.range, by_name.range_bearing.range)
        np.testing.assert_array_equal(s.ground_truth.poses, by_name.ground_truth.poses)


def test_a_directory_without_a_file_the_format_needs_names_it(tmp_path):
    from slamarena.datasets import DatasetNotFoundError
    from slamarena.errors import UserError

    _recording(tmp_path)
    (tmp_path / "Landmark_Groundtruth.dat").unlink()
    with pytest.raises(DatasetNotFoundError) as err:
        load(f"utias:{tmp_path}/robot2")
    message = str(err.value)
    assert isinstance(err.value, UserError) and str(tmp_path / "Landmark_Groundtruth.dat") in message
    assert str(tmp_path / "Barcodes.dat") not in message and "utias:<path>/robot<k>" in message


@pytest.mark.parametrize(
    "rows, line, fragment",
    [
        (["1.0 0.1 0.0", "2.0 0.1"], 6, "3 numeric fields"),  # truncated line
        (["1.0 0.1 0.0", "2.0 abc 0.0"], 6, "numeric"),  # non-numeric field
        (["1.0 0.1 0.0", "2.0 0.1 0.0 7"], 6, "3 numeric fields"),  # extra field
        (["2.0 0.1 0.0", "1.0 0.1 0.0"], 6, "non-decreasing time"),  # time going back
    ],
)
def test_malformed_odometry_names_file_and_line(tmp_path, rows, line, fragment):
    _write(tmp_path / "Barcodes.dat", 4, ["6 63"])
    _write(tmp_path / "Landmark_Groundtruth.dat", 4, ["6 1 2 0 0"])
    _write(tmp_path / "Robot1_Measurement.dat", 4, [])
    _write(tmp_path / "Robot1_Odometry.dat", 4, rows)
    with pytest.raises(DataFormatError) as err:
        load(f"utias:{tmp_path}/robot1")
    assert err.value.line == line and "Robot1_Odometry.dat" in str(err.value) and fragment in str(err.value)


def _read_with(tmp_path, odometry=None, measurement=None, barcodes=None, landmarks=None):
    """The small recording with some files' rows replaced."""
    _recording(tmp_path)
    for name, rows in (
        ("Robot2_Odometry.dat", odometry),
        ("Barcodes.dat", barcodes),
        ("Landmark_Groundtruth.dat", landmarks),
    ):
        if rows is not None:
            _write(tmp_path / name, 4, rows)
    if measurement is not None:
        (tmp_path / "Robot2_Measurement.dat.gz").unlink()
        _write(tmp_path / "Robot2_Measurement.dat", 4, measurement)
    return load(f"utias:{tmp_path}/robot2")


@pytest.mark.parametrize(
    "odometry, measurement, dropped",
    [
        (["10.0 0.1 0.0", "10.5 1e300 0.1", "11.0 0.0 0.0"], None, {"odometry": [6], "measurement": []}),
        (["10.0 0.1 0.0", "10.5 0.3 -50", "11.0 0.0 0.0"], None, {"odometry": [6], "measurement": []}),
        (None, ["10.2 63 1.5 0.1", "10.7 81 -1.0 0.0", "10.9 81 1e300 -0.2"], {"odometry": [], "measurement": [6, 7]}),
        (None, ["10.2 63 1.5 7.0", "10.9 81 2.5 -0.2"], {"odometry": [], "measurement": [5]}),
    ],
)
def test_a_value_outside_its_physical_range_is_dropped_and_counted_with_its_line(
    tmp_path, odometry, measurement, dropped
):
    """v = 1e300 m/s, ω = −50 rad/s, a negative or 1e300 m range, a bearing of 7 rad: the row is dropped, its line
    listed per file in meta (``slamarena data info`` shows it) and warned about; dead reckoning stays finite."""
    with pytest.warns(DataWarning, match="dropped"):
        s = _read_with(tmp_path, odometry=odometry, measurement=measurement)
    assert s.meta["dropped_lines"]["out_of_range"] == dropped
    assert s.summary()["meta"]["dropped_lines"]["out_of_range"] == dropped
    assert np.all(np.abs(s.motion.v) <= 5) and np.all((s.range_bearing.range >= 0) & (s.range_bearing.range < 10))
    assert np.all(np.isfinite(DeadReckoning().run(s).poses))


@pytest.mark.parametrize(
    "files, line, fragment",
    [
        (
            dict(landmarks=["6 1.0 2.0 0.01 0.02", "7 3.0 4.0 0.01 0.02", "6 5.0 6.0 0.01 0.02"]),
            7,
            "unique landmark subject ids (also declared on line 5)",
        ),
        (dict(measurement=["10.2 63 1.5 0.1", "10.9 14.5 2.5 -0.2"]), 6, "non-negative integer barcode"),
        (dict(barcodes=["1 5", "2 14", "6 63", "7 63"]), 8, "unique barcode ids (also declared on line 7)"),
        (dict(barcodes=["1 5", "2.5 14", "6 63"]), 6, "non-negative integer subject and barcode"),
    ],
)
def test_bad_ids_name_file_and_line(tmp_path, files, line, fragment):
    """A duplicate landmark id or barcode, a barcode 14.5 (not 14: robot 2's), a subject 2.5."""
    with pytest.raises(DataFormatError) as err:
        _read_with(tmp_path, **files)
    assert err.value.line == line and fragment in str(err.value)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    """A file saved "with BOM" (Notepad, Excel) reads as without it; line numbers are unchanged."""
    plain = _read_with(tmp_path / "plain")
    _recording(tmp_path / "bom")
    for name in ("Barcodes.dat", "Robot2_Odometry.dat"):
        path = tmp_path / "bom" / name
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    bom = load(f"utias:{tmp_path / 'bom'}/robot2")
    np.testing.assert_array_equal(bom.motion.v, plain.motion.v)
    np.testing.assert_array_equal(bom.range_bearing.landmark_id, plain.range_bearing.landmark_id)
