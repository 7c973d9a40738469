"""Interlaced laser scans: the Scans representation (per-scan ``angle_offset`` and ``beam_count``)
and the CARMEN reader keeping every beam layout of fr-clinic in one stream (values checked by hand
with ``bzcat … | awk``)."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged, staged

from slamarena.datasets.formats import carmen
from slamarena.datasets.sequence import Scans, Sequence

CLINIC = "radish_laser_logs/fr-clinic_robotlaser.clf.bz2"


def _interlaced() -> Scans:
    return Scans(
        t=[0.0, 1.0, 2.0],
        ranges=[[1.0, 2.0, 3.0], [4.0, 5.0, 99.0], [6.0, 7.0, 8.0]],
        angles=[-0.1, 0.0, 0.1],
        pose=np.arange(9.0).reshape(3, 3),
        angle_offset=[0.0, 0.02, 0.05],
        beam_count=[3, 2, 3],
    )


# --------------------------------------------------------------------------- the representation
def test_beams_apply_the_offset_and_drop_the_padding():
    s = _interlaced()
    r, a = s.beams(1)
    assert np.array_equal(r, [4.0, 5.0]) and np.allclose(a, [-0.08, 0.02])
    r, a = s.beams(2)
    assert np.array_equal(r, [6.0, 7.0, 8.0]) and np.allclose(a, [-0.05, 0.05, 0.15])
    assert np.isnan(s.ranges[1, 2])  # the padding is stored as NaN, whatever the caller put there
    uniform = Scans(t=[0.0], ranges=[[1.0, 2.0]], angles=[0.0, 0.5])
    r, a = uniform.beams(0)
    assert np.array_equal(r, [1.0, 2.0]) and np.array_equal(a, [0.0, 0.5]) and r.dtype == np.float64


def test_padding_is_not_a_bad_reading_but_a_real_nan_is():
    s = _interlaced()
    assert s.nonfinite_count() == 0
    assert Sequence(name="x", scans=s).summary()["scans"]["nonfinite_rows"] == 0
    ranges = s.ranges.copy()
    ranges[2, 1] = np.inf
    ranges[1, 0] = np.nan
    assert (
        Scans(
            t=s.t, ranges=ranges, angles=s.angles, angle_offset=s.angle_offset, beam_count=s.beam_count
        ).nonfinite_count()
        == 2
    )


@pytest.mark.parametrize("index", [[1, 2], np.array([False, True, True]), slice(1, None)])
def test_select_keeps_offsets_and_beam_counts_per_row(index):
    s = _interlaced()
    part = s.select(index)
    assert np.allclose(part.angle_offset, [0.02, 0.05]) and np.array_equal(part.beam_count, [2, 3])
    for k in (0, 1):
        for got, want in zip(part.beams(k), s.beams(k + 1)):
            assert np.array_equal(got, want)
    assert np.array_equal(part.angles, s.angles) and np.array_equal(part.pose, s.pose[1:])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"angle_offset": [0.0, 0.1]}, r"angle_offset must be \(3,\)"),
        ({"angle_offset": [0.0, np.nan, 0.0]}, "angle_offset has non-finite"),
        ({"angle_offset": [0.0, np.inf, 0.0]}, "angle_offset has non-finite"),
        ({"beam_count": [3, 3]}, r"beam_count must be \(3,\)"),
        ({"beam_count": [3, 4, 3]}, r"integers in \[0, 3\]"),
        ({"beam_count": [3, -1, 3]}, r"integers in \[0, 3\]"),
        ({"beam_count": [3, 2.5, 3]}, r"integers in \[0, 3\]"),
    ],
)
def test_invalid_offsets_and_counts_are_rejected(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Scans(t=[0.0, 1.0, 2.0], ranges=np.ones((3, 3)), angles=[0.0, 0.1, 0.2], **kwargs)


# --------------------------------------------------------------------------- fr-clinic (real log)
@pytest.fixture(scope="module")
def clinic():
    return load_staged("carmen:fr-clinic")


@pytest.mark.realdata
def test_fr_clinic_keeps_all_four_layouts_in_one_stream(clinic):
    sc, meta = clinic.scans, clinic.meta
    assert (
        len(sc) == 6917
        and sc.ranges.shape == (6917, 181)
        and meta["dropped_scans_other_layout"] == 0
        and meta["interlaced"]
    )
    layouts = {(l["beams"], round(l["start"], 6)): l["scans"] for l in meta["beam_layouts"]}
    assert layouts == {(181, -1.570796): 1748, (180, -1.566433): 1709, (180, -1.56207): 1725, (180, -1.557706): 1735}
    assert all(l["chosen"] and l["step"] == 0.017453 for l in meta["beam_layouts"])
    assert np.allclose(sc.angles[[0, 1, 180]], -1.570796 + 0.017453 * np.array([0, 1, 180]))
    quarter = np.round(sc.angle_offset / np.radians(0.25)).astype(int)  # offsets 0, ¼°, ½°, ¾°
    assert np.allclose(sc.angle_offset, quarter * np.radians(0.25), atol=1e-6)
    assert np.bincount(quarter).tolist() == [1748, 1709, 1725, 1735]
    assert np.array_equal(sc.beam_count == 181, quarter == 0) and set(np.unique(sc.beam_count)) == {180, 181}
    assert sc.nonfinite_count() == 0 and clinic.summary()["scans"]["nonfinite_rows"] == 0
    assert np.isnan(sc.ranges[quarter > 0, 180]).all() and meta["no_return_readings"] == 156462  # awk: readings ≥ 80


@pytest.mark.realdata
def test_fr_clinic_first_and_last_scans(clinic):
    sc = clinic.scans
    r, a = sc.beams(0)  # line 1: ROBOTLASER1 0 -1.570796 … 181 14.120 7.160 49.610 …
    assert r.size == 181 and np.allclose(r[:3], [14.12, 7.16, 49.61]) and np.isclose(r[-1], 15.88)
    assert np.isclose(a[0], -1.570796) and np.isclose(a[-1], -1.570796 + 180 * 0.017453) and np.allclose(sc.pose[0], 0)
    r, a = sc.beams(1)  # line 2: -1.566433 … 180 14.150 6.730 49.630 … 11.080
    assert r.size == 180 and np.allclose(r[:3], [14.15, 6.73, 49.63]) and np.isclose(r[-1], 11.08)
    assert np.isclose(a[0], -1.566433) and np.isclose(a[1] - a[0], 0.017453)
    assert sc.t[0] == 1232658478.161285 and sc.t[1] == 1232658641.501290
    r, a = sc.beams(6916)  # last line: -1.566433 … 180 8.450 9.390 81.910 … 8.540, robot 2.074723 -10.915255 0.207979
    assert r.size == 180 and np.allclose(r[:3], [8.45, 9.39, 81.91]) and np.isclose(r[-1], 8.54)
    assert np.isclose(a[0], -1.566433) and np.isclose(a[-1], -1.566433 + 179 * 0.017453)
    assert (
        np.allclose(sc.pose[-1], [2.074723, -10.915255, 0.207979])
        and clinic.meta["scan_ipc_timestamp"][-1] == 1232663298.321285
    )
    assert np.allclose(sc.mount, [0.22, 0, 0], atol=1e-6) and sc.max_range == 80.0


@pytest.mark.realdata
def test_fr_clinic_single_layout_on_request(clinic):
    path = staged(CLINIC)
    one = carmen.read(path, max_range=80.0, interlaced=False)
    assert len(one.scans) == 1748 and one.meta["dropped_scans_other_layout"] == 5169 and not one.meta["interlaced"]
    assert one.scans.angle_offset is None and one.scans.beam_count is None
    full = clinic.scans.beam_count == 181
    assert np.array_equal(one.scans.ranges, clinic.scans.ranges[full]) and np.array_equal(
        one.scans.t, clinic.scans.t[full]
    )
    assert np.array_equal(one.scans.angles, clinic.scans.angles)
    b180 = carmen.read(path, max_range=80.0, beams=180)  # the most common 180-beam layout: from −89.25°
    assert len(b180.scans) == 1735 and np.isclose(b180.scans.angles[0], -1.557706) and b180.scans.ranges.shape[1] == 180
    assert b180.meta["dropped_scans_other_layout"] == 6917 - 1735 and b180.scans.angle_offset is None


# --------------------------------------------------------------------------- small logs
def _robotlaser(start, res, ranges, t, x=0.0):
    n = len(ranges)
    body = " ".join(f"{r:.3f}" for r in ranges)
    return (
        f"ROBOTLASER1 0 {start:.6f} 3.141593 {res:.6f} 10.0 0.01 0 {n} {body} 0 "
        f"{x + 0.2:.6f} 0 0 {x:.6f} 0 0 0 0 0 0 0 {t:.6f} host {t:.6f}\n"
    )


def test_interlaced_layouts_merge_and_incompatible_ones_are_dropped(tmp_path):
    lines = [
        _robotlaser(-0.6, 0.4, [1, 2, 3, 4], 1.0),
        _robotlaser(-0.5, 0.4, [5, 6, 7, 8], 2.0),  # interlaced: offset 0.1
        _robotlaser(-0.6, 0.4, [1, 2, 3, 4], 3.0),
        _robotlaser(-0.4, 0.4, [9, 9.5, 9.9], 4.0),  # interlaced, one beam fewer: offset 0.2
        _robotlaser(-0.6, 0.3, [1, 1, 1, 1], 5.0),  # another step: dropped
        _robotlaser(-0.6, 0.4, [1, 1, 1, 1, 1, 1], 6.0),  # another field of view: dropped
        _robotlaser(-0.6 + 0.4, 0.4, [1, 1, 1, 1], 7.0),  # a whole step later: not interlaced, dropped
    ]
    path = tmp_path / "interlaced.clf"
    path.write_text("".join(lines))
    s = carmen.read(path)
    sc = s.scans
    assert s.meta["interlaced"] and s.meta["dropped_scans_other_layout"] == 3 and len(sc) == 4
    assert np.allclose(sc.t, [1, 2, 3, 4]) and np.allclose(sc.angles, [-0.6, -0.2, 0.2, 0.6])
    assert np.allclose(sc.angle_offset, [0, 0.1, 0, 0.2]) and np.array_equal(sc.beam_count, [4, 4, 4, 3])
    r, a = sc.beams(3)
    assert np.allclose(r, [9, 9.5, 9.9]) and np.allclose(a, [-0.4, 0.0, 0.4])
    assert sc.max_range == 10.0 and s.meta["no_return_readings"] == 0
    kept = {(l["beams"], round(l["start"], 3), round(l["step"], 3)): l["chosen"] for l in s.meta["beam_layouts"]}
    assert kept == {
        (4, -0.6, 0.4): True,
        (4, -0.5, 0.4): True,
        (3, -0.4, 0.4): True,
        (4, -0.6, 0.3): False,
        (6, -0.6, 0.4): False,
        (4, -0.2, 0.4): False,
    }
    single = carmen.read(path, interlaced=False)
    assert len(single.scans) == 2 and single.scans.angle_offset is None and np.allclose(single.scans.t, [1, 3])


@pytest.mark.realdata
def test_fr_clinic_offsets_are_the_ones_the_scans_show(clinic):
    """Consecutive scans (0.2 m apart by odometry) of layouts ½° or ¾° apart: the extra rotation
    of scan j that best overlays it on scan k is ≈ 0 with the stated offsets, and ≈ the offset
    difference when both scans are read at the base angles (offsets ignored)."""
    from scipy.spatial import cKDTree

    from slamarena.datasets.geometry import between, compose, transform_points

    sc = clinic.scans
    diff = np.degrees(sc.angle_offset[1:] - sc.angle_offset[:-1])
    pairs = np.flatnonzero(np.abs(diff) > 0.4)[:100]
    candidates = np.radians(np.arange(-1.2, 1.2001, 0.05))
    best = {"honoured": [], "ignored": []}
    for k in pairs:
        (ra, aa), (rb, ab) = sc.beams(k), sc.beams(k + 1)
        a_ok, b_ok = ra < 15, rb < 15
        rel = between(compose(sc.pose[k], sc.mount), compose(sc.pose[k + 1], sc.mount))
        for label, shift_a, shift_b in (
            ("honoured", 0.0, 0.0),
            ("ignored", sc.angle_offset[k], sc.angle_offset[k + 1]),
        ):
            tree = cKDTree(
                np.column_stack([ra[a_ok] * np.cos(aa[a_ok] - shift_a), ra[a_ok] * np.sin(aa[a_ok] - shift_a)])
            )
            cost = []
            for c in candidates:
                a = ab[b_ok] - shift_b + c
                d, _ = tree.query(transform_points(rel, np.column_stack([rb[b_ok] * np.cos(a), rb[b_ok] * np.sin(a)])))
                cost.append(np.mean(np.minimum(d, 0.3) ** 2))
            best[label].append(np.degrees(candidates[int(np.argmin(cost))]))
    honoured, ignored, stated = np.array(best["honoured"]), np.array(best["ignored"]), diff[pairs]
    for sign in (-1, 1):
        group = np.sign(stated) == sign
        assert abs(np.median(honoured[group])) < 0.15, (sign, np.median(honoured[group]))
        assert abs(np.median(ignored[group] - stated[group])) < 0.15, (sign, np.median(ignored[group] - stated[group]))
        assert abs(np.median(ignored[group])) > 0.4
