"""CMU Plaza reader on the staged runs (values checked by hand against the text files and SOURCE.md)."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged, staged
from pydantic import ValidationError

from slamarena.datasets import DataFormatError, load
from slamarena.datasets.formats import plaza
from slamarena.datasets.formats.plaza import read_mat
from slamarena.datasets.geometry import compose, interpolate_poses, wrap_angle

pytestmark = pytest.mark.realdata

#: SOURCE.md: beacon id → true position, per run
BEACONS = {
    "Plaza1": {0: (-46.62, 11.03), 1: (11.04, -6.96), 6: (22.05, 23.85), 5: (-17.66, 59.01)},
    "Plaza2": {1: (-68.93, 18.38), 6: (-37.58, 69.23), 0: (-33.62, 26.97), 5: (1.71, -5.81)},
}


@pytest.fixture(scope="module")
def plaza1():
    return load_staged("plaza:Plaza1")


@pytest.fixture(scope="module")
def plaza2():
    return load_staged("plaza:Plaza2")


def test_plaza1_streams_first_and_last_rows(plaza1):
    m, r = plaza1.motion, plaza1.beacon_ranges
    assert len(m) == 9657 and len(r) == 3529
    # DR line 1: "3.8570532019138336e+003  2.3483858154428326e-004  -5.2000000000163027e-005"
    assert m.t[0] == 3857.0532019138336
    assert np.array_equal(m.delta[0], [2.3483858154428326e-04, 0.0, -5.2000000000163027e-05])
    assert m.t[-1] == 5790.2992548942566 and m.delta[-1, 0] == 1.7622697994741719e-04
    # TD line 1: "3.8580620000362396e+003  2  5  6.5466007843625079e+001"; last: "... 2  1  6.1841339643006052e+001"
    assert (r.t[0], r.beacon_id[0], r.range[0]) == (3858.0620000362396, 5, 6.5466007843625079e01)
    assert (r.t[-1], r.beacon_id[-1], r.range[-1]) == (5790.1719999313354, 1, 6.1841339643006052e01)
    assert sorted(np.unique(r.beacon_id).tolist()) == [0, 1, 5, 6]


def test_plaza1_out_of_order_ranges_are_sorted_and_counted(plaza1):
    r = plaza1.beacon_ranges
    assert plaza1.meta["range_rows_out_of_order"] == 120 + 97  # after lines 1989 and 2867 (SOURCE-checked)
    assert np.all(np.diff(r.t) >= 0)
    # TD line 1989, "5.0392500000000000e+003  2  0  2.8106442328352951e+001", is now in its place in time
    k = np.flatnonzero(r.t == 5039.25)
    assert k.size == 1 and r.beacon_id[k[0]] == 0 and r.range[k[0]] == 2.8106442328352951e01
    assert r.t[k[0] - 1] < 5039.25 < r.t[k[0] + 1]
    with pytest.raises(DataFormatError, match=r"Plaza1_TD.txt:1989: expected non-decreasing time"):
        load("plaza:Plaza1", strict_time=True)


def test_plaza2_first_and_last_rows(plaza2):
    m, r = plaza2.motion, plaza2.beacon_ranges
    assert len(m) == 4090 and len(r) == 1816 and plaza2.meta["range_rows_out_of_order"] == 0
    assert m.t[0] == 3152.0999939441681 and m.delta[0, 2] == -6.7308112020647570e-04
    assert m.t[-1] == 3561.5232760906219 and m.delta[-1, 0] == 1.4461323679445086e-03
    assert (r.t[0], r.beacon_id[0], r.range[0]) == (3152.0127000072971, 1, 4.7260574538515279e01)
    assert (r.t[-1], r.beacon_id[-1], r.range[-1]) == (3561.3715173983946, 5, 5.8662150683311602e01)


@pytest.mark.parametrize("run", ["Plaza1", "Plaza2"])
def test_ground_truth_and_beacons(run, plaza1, plaza2):
    seq = plaza1 if run == "Plaza1" else plaza2
    assert len(seq.ground_truth) == {"Plaza1": 9658, "Plaza2": 4091}[run]
    for beacon, xy in BEACONS[run].items():
        np.testing.assert_allclose(seq.landmarks.position(beacon), xy, atol=0.005)
    np.testing.assert_array_equal(seq.initial_pose, seq.ground_truth.poses[0])
    # the odometry rows are stamped at the ground-truth stamps after the first
    np.testing.assert_array_equal(seq.motion.t, seq.ground_truth.t[1:])


def test_plaza2_ground_truth_heading_is_turned_to_the_direction_of_travel(plaza1, plaza2):
    assert not plaza1.meta["ground_truth_heading"]["rotated_by_pi"]
    meta = plaza2.meta["ground_truth_heading"]
    assert meta["rotated_by_pi"] and abs(abs(meta["travel_minus_heading_median_rad"]) - np.pi) < 0.05
    assert meta["steps_agreeing"] > 0.99
    raw = read_mat(staged("plaza_range_only/Plaza2_.mat"), ("GT",))["GT"]
    np.testing.assert_allclose(wrap_angle(plaza2.ground_truth.poses[:, 2] - raw[:, 3] - np.pi), 0.0, atol=1e-12)
    kept = load("plaza:Plaza2", align_heading=False)
    np.testing.assert_allclose(kept.ground_truth.poses[:, 2], wrap_angle(raw[:, 3]), atol=1e-12)
    # after the rotation the heading agrees with the direction of travel, as in Plaza1
    offset, agreeing = plaza.heading_offset(plaza2.ground_truth.poses)
    assert abs(offset) < 0.05 and agreeing > 0.99


def test_plaza1_odometry_integrates_to_the_ground_truth(plaza1):
    """x ⊕ (Δd, 0, Δθ) from the first ground-truth pose stays within 4.4 m of the truth over 1.86 km
    (the other order, turn then move, is also within a few metres: this checks units and frames)."""
    pose = plaza1.initial_pose.copy()
    path = [pose]
    for d in plaza1.motion.delta:
        pose = compose(pose, d)
        path.append(pose)
    err = np.hypot(*(np.array(path)[:, :2] - plaza1.ground_truth.poses[:, :2]).T)
    assert err.max() < 4.5 and err.mean() < 1.7


def test_text_and_mat_copies_agree_and_ranges_are_biased(plaza1):
    mat = read_mat(staged("plaza_range_only/Plaza1_.mat"), ("DR", "TD"))
    np.testing.assert_array_equal(mat["DR"][:, 1], plaza1.motion.delta[:, 0])
    np.testing.assert_array_equal(np.sort(mat["TD"][:, 0]), plaza1.beacon_ranges.t)
    r = plaza1.beacon_ranges
    truth = interpolate_poses(plaza1.ground_truth.t, plaza1.ground_truth.poses, r.t)
    beacons = np.array([plaza1.landmarks.position(b) for b in r.beacon_id])
    residual = r.range - np.hypot(*(beacons - truth[:, :2]).T)
    assert 2.5 < np.median(residual) < 3.1 and 0.9 < residual.std() < 1.4  # research/method/readers.md quotes these


def test_malformed_files_name_file_and_line(tmp_path):
    src = staged("plaza_range_only/Plaza2_TD.txt")
    lines = src.read_text().splitlines()
    lines[6] = "  3.1536e+003\t  2.0e+000\t  1.0e+000"
    bad = tmp_path / "Plaza2_TD.txt"
    bad.write_text("\n".join(lines) + "\n")
    dr = staged("plaza_range_only/Plaza2_DR.txt")
    with pytest.raises(DataFormatError, match=r"Plaza2_TD.txt:7: expected 4 numeric fields"):
        plaza.read_run(dr, bad)
    lines[6] = "  3.1536e+003\t  2.0e+000\t  -1.0e+000\t 4.0e+001"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFormatError, match=r"Plaza2_TD.txt:7: expected non-negative integer beacon ids"):
        plaza.read_run(dr, bad)
    without_truth = plaza.read_run(dr, src)
    assert (
        without_truth.ground_truth is None
        and without_truth.landmarks is None
        and len(without_truth.beacon_ranges) == 1816
    )


def test_a_params_model_and_keywords_read_alike():
    files = [staged(f"plaza_range_only/Plaza2{suffix}") for suffix in ("_DR.txt", "_TD.txt", "_.mat")]
    given = plaza.read_run(*files, params=plaza.PlazaParams(align_heading=False))
    keywords = plaza.read_run(*files, align_heading=False)
    assert plaza.read_run.Params is plaza.PlazaParams and issubclass(plaza.read.Params, plaza.PlazaParams)
    assert not given.meta["ground_truth_heading"]["rotated_by_pi"] and given.meta == keywords.meta
    np.testing.assert_array_equal(given.ground_truth.poses, keywords.ground_truth.poses)
    with pytest.raises(ValidationError, match="align_headings"):
        plaza.read_run(*files, align_headings=False)


def test_mat_files_scipy_cannot_read_name_the_file(tmp_path):
    from scipy.io import savemat

    savemat(tmp_path / "ok.mat", {"GT": np.arange(8.0).reshape(2, 4), "name": "text"})
    np.testing.assert_array_equal(read_mat(tmp_path / "ok.mat", ("GT",))["GT"], np.arange(8.0).reshape(2, 4))
    (tmp_path / "garbage.mat").write_bytes(b"MATLAB" + b"\x00" * 50)
    cases = {
        "garbage.mat": (("GT",), "a MATLAB v5 MAT-file"),
        "ok.mat": (("TL",), "a variable 'TL', got 'no such variable'"),
    }
    for name, (names, message) in cases.items():
        with pytest.raises(DataFormatError, match=message) as info:
            read_mat(tmp_path / name, names)
        assert name in str(info.value)
    with pytest.raises(DataFormatError, match="real numeric matrix for variable 'name'"):
        read_mat(tmp_path / "ok.mat", ("name",))
    truncated = (tmp_path / "ok.mat").read_bytes()
    (tmp_path / "cut.mat").write_bytes(truncated[: len(truncated) // 2])
    with pytest.raises(DataFormatError, match="cut.mat"):
        read_mat(tmp_path / "cut.mat", ("GT",))


def test_a_value_outside_its_physical_range_is_dropped_and_counted_with_its_line(tmp_path):
    """Ranges of −3 m and 1e300 m, an odometry step of 1e300 m: dropped, their lines listed per file, warned about."""
    from slamarena.datasets.errors import DataWarning

    dr, td = tmp_path / "X_DR.txt", tmp_path / "X_TD.txt"
    dr.write_text("1.0\t0.2\t0.0\n1.2\t1e300\t0.0\n1.4\t0.2\t0.01\n")
    td.write_text("1.0\t0\t1\t10.5\n1.1\t0\t1\t-3.0\n1.2\t0\t2\t1e300\n1.3\t0\t2\t20.0\n")
    with pytest.warns(DataWarning, match="dropped"):
        s = plaza.read_run(dr, td)
    assert s.meta["dropped_lines"]["out_of_range"] == {"odometry": [2], "ranges": [2, 3]}
    assert s.beacon_ranges.range.tolist() == [10.5, 20.0] and s.meta["range_rows"] == 4
    np.testing.assert_array_equal(s.motion.delta[:, 0], [0.2, 0.2])
