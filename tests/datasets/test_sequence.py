"""slamarena.datasets.sequence — validation on construction, the time-ordered merge, summary, Twist.from_stamps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slamarena.datasets.sequence import (
    STREAMS,
    BeaconRanges,
    Gps,
    Heading,
    Increments,
    LandmarkMap,
    Noise,
    RangeBearing,
    Scans,
    Sequence,
    Trajectory,
    Twist,
)


def twist(t=(0.0, 0.1, 0.2), v=(1.0, 1.0, 1.0), w=(0.0, 0.1, 0.2), dt=(0.1, 0.1, 0.1)):
    return Twist(t=np.array(t), v=np.array(v), omega=np.array(w), dt=np.array(dt))


# ---------------------------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: twist(t=(0.0, 0.2, 0.1)), "not monotonic: t\\[1\\]=0.2 > t\\[2\\]=0.1"),
        (lambda: twist(v=(1.0, 1.0)), "Twist.v has 2 rows but Twist.t has 3"),
        (lambda: twist(t=(0.0, np.nan, 0.2)), "Twist.t has non-finite"),
        (lambda: twist(dt=(0.1, np.inf, 0.1)), "Twist.dt has non-finite"),
        (lambda: twist(dt=(0.1, 0.0, 0.1)), "dt must be > 0"),
        (lambda: Increments(t=[0.0, 1.0], delta=np.zeros((3, 3))), "delta has 3 rows"),
        (lambda: Increments(t=[0.0, 1.0], delta=np.zeros((2, 3)), cov=np.zeros((1, 3, 3))), "cov has 1 rows"),
        (lambda: RangeBearing(t=[1.0, 0.5], range=[1, 1], bearing=[0, 0], landmark_id=[0, 1]), "not monotonic"),
        (lambda: RangeBearing(t=[0.0], range=[1, 2], bearing=[0], landmark_id=[0]), "range has 2 rows"),
        (lambda: BeaconRanges(t=[0.0, 1.0], range=[1.0], beacon_id=[0, 1]), "range has 1 rows"),
        (lambda: BeaconRanges(t=[0.0], range=[1.0], beacon_id=[-1]), "beacon_id must be >= 0"),
        (lambda: Gps(t=[0.0, 1.0], xy=np.zeros((3, 2))), "xy has 3 rows"),
        (lambda: Heading(t=[[0.0, 1.0]], yaw=[0.0, 0.0]), "must be 1-D"),
        (lambda: Trajectory(t=[0.0, 1.0], poses=[[0, 0, 0], [np.nan, 0, 0]]), "poses has non-finite"),
        (lambda: Trajectory(t=[0.0, 1.0, 2.0], poses=np.zeros((2, 3))), "poses has 2 rows"),
        (lambda: Scans(t=[0.0], ranges=np.ones((1, 4)), angles=np.zeros(3)), "ranges must be \\(S, 3\\)"),
        (lambda: Scans(t=[0.0, 1.0], ranges=np.ones((1, 3)), angles=np.zeros(3)), "ranges has 1 rows"),
        (lambda: Scans(t=[0.0], ranges=np.ones((1, 3)), angles=[0.0, np.nan, 1.0]), "angles has non-finite"),
        (lambda: LandmarkMap(ids=[1, 1], xy=np.zeros((2, 2))), "not unique"),
        (lambda: LandmarkMap(ids=[1, 2], xy=[[0, 0], [np.inf, 0]]), "xy has non-finite"),
        (lambda: Sequence("s", initial_pose=[0.0, np.nan, 0.0]), "initial_pose has non-finite"),
    ],
)
def test_invalid_streams_raise_a_clear_error(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_wrong_stream_types_raise():
    with pytest.raises(TypeError, match="motion"):
        Sequence("s", motion=Gps(t=[0.0], xy=[[0.0, 0.0]]))
    with pytest.raises(TypeError, match="range_bearing"):
        Sequence("s", range_bearing=twist())
    with pytest.raises(TypeError, match="beacon_ranges"):
        Sequence("s", beacon_ranges=Gps(t=[0.0], xy=[[0.0, 0.0]]))


def test_measurements_may_be_nonfinite_and_are_counted():
    tw = twist(v=(1.0, np.nan, 1.0), w=(0.0, 0.0, np.inf))
    assert tw.nonfinite_count() == 2
    scans = Scans(t=[0.0, 1.0], ranges=[[1.0, np.nan], [1.0, 2.0]], angles=[0.0, 1.0])
    assert scans.nonfinite_count() == 1
    assert Sequence("s", motion=tw, scans=scans).summary()["scans"]["nonfinite_rows"] == 1


def test_trajectory_wraps_headings_and_select_keeps_per_scan_fields():
    tr = Trajectory(t=[0.0], poses=[[0.0, 0.0, 3 * math.pi]])
    assert tr.poses[0, 2] == pytest.approx(math.pi)
    scans = Scans(
        t=[0.0, 1.0, 2.0], ranges=np.ones((3, 3)), angles=[0.0, 0.1, 0.2], pose=np.zeros((3, 3)), max_range=5.0
    )
    part = scans.select(slice(1, 3))
    assert part.ranges.shape == (2, 3) and part.pose.shape == (2, 3) and part.angles.shape == (3,)
    assert part.max_range == 5.0


# ---------------------------------------------------------------------------------------------- events
@pytest.fixture
def seq():
    return Sequence(
        "toy",
        motion=twist(t=(0.0, 0.1, 0.2)),
        range_bearing=RangeBearing(
            t=[0.1, 0.1, 0.1, 0.2, 0.25], range=[1, 2, 3, 4, 5], bearing=[0] * 5, landmark_id=[0, 1, -1, 2, 0]
        ),
        beacon_ranges=BeaconRanges(t=[0.1, 0.2, 0.2], range=[3.0, 4.0, np.nan], beacon_id=[5, 5, 6]),
        gps=Gps(t=[0.0, 0.2], xy=np.zeros((2, 2))),
        heading=Heading(t=[0.1, 0.15], yaw=[0.0, 0.0]),
        scans=Scans(t=[0.2], ranges=np.ones((1, 4)), angles=np.linspace(-1, 1, 4), max_range=30.0),
        ground_truth=Trajectory(t=[0.0, 0.3], poses=np.zeros((2, 3))),
        landmarks=LandmarkMap(ids=[0, 1, 2], xy=np.zeros((3, 2))),
        noise=Noise(twist_cov=np.eye(2), yaw_var=0.5),
        meta={"source": "unit test", "array": np.zeros(3), "count": 3},
    )


def test_events_are_time_ordered_motion_first_and_observation_sets_grouped(seq):
    ev = list(seq.events())
    got = [(e.t, e.stream, e.start, e.stop) for e in ev]
    assert got == [
        (0.0, "motion", 0, 1),
        (0.0, "gps", 0, 1),
        (0.1, "motion", 1, 2),
        (0.1, "range_bearing", 0, 3),
        (0.1, "beacon_ranges", 0, 1),
        (0.1, "heading", 0, 1),
        (0.15, "heading", 1, 2),
        (0.2, "motion", 2, 3),
        (0.2, "range_bearing", 3, 4),
        (0.2, "beacon_ranges", 1, 3),
        (0.2, "gps", 1, 2),
        (0.2, "scans", 0, 1),
        (0.25, "range_bearing", 4, 5),
    ]
    t, code, start, stop = seq.event_table()
    assert np.all(np.diff(t) >= 0)
    assert [STREAMS[c] for c in code[:2]] == ["motion", "gps"]


def test_events_of_an_empty_sequence():
    assert list(Sequence("empty").events()) == []
    assert Sequence("empty").t0 == 0.0


def test_summary_contents(seq):
    s = seq.summary()
    assert (s["t0"], s["t1"]) == (0.0, 0.25) and s["duration_s"] == 0.25
    assert s["motion"] == {"kind": "Twist", "count": 3, "rate_hz": pytest.approx(10.0), "nonfinite_rows": 0}
    rb = s["range_bearing"]
    assert (rb["count"], rb["known_ids"], rb["unknown_id_rows"], rb["observation_sets"]) == (5, 3, 1, 3)
    assert s["beacon_ranges"] == {
        "kind": "BeaconRanges",
        "count": 3,
        "rate_hz": pytest.approx(20.0),
        "nonfinite_rows": 1,
        "beacons": 2,
    }
    assert s["scans"]["beams"] == 4 and s["scans"]["max_range"] == 30.0 and "rate_hz" not in s["scans"]
    assert "interlaced_offsets" not in s["scans"]
    interlaced = Scans(
        t=[0.0, 1.0, 2.0], ranges=np.ones((3, 4)), angles=np.linspace(-1, 1, 4), angle_offset=[0.0, 0.1, 0.0]
    )
    assert Sequence("i", scans=interlaced).summary()["scans"]["interlaced_offsets"] == 2
    assert s["ground_truth"] == {"count": 2, "t0": 0.0, "t1": 0.3}
    assert s["landmarks"] == 3
    assert (
        s["noise"]["twist_cov"] == [[1.0, 0.0], [0.0, 1.0]]
        and s["noise"]["yaw_var"] == 0.5
        and s["noise"]["gps_cov"] is None
    )
    assert s["meta"] == {"source": "unit test", "count": 3}  # arrays are left out


def test_start_pose_fallbacks(seq):
    assert np.array_equal(seq.start_pose, np.zeros(3))
    gt = Trajectory(t=[1.0], poses=[[1.0, 2.0, 0.5]])
    assert np.array_equal(Sequence("a", ground_truth=gt).start_pose, [1.0, 2.0, 0.5])
    assert np.array_equal(Sequence("b", ground_truth=gt, initial_pose=[3.0, 0.0, 0.0]).start_pose, [3.0, 0.0, 0.0])


def test_range_bearing_z_matrix(seq):
    z = seq.range_bearing.z
    assert z.shape == (5, 3) and z[2, 2] == -1.0 and z[0, 0] == 1.0


# ---------------------------------------------------------------------------------------------- from_stamps
def test_twist_from_stamps_holds_each_command_until_the_next():
    tw = Twist.from_stamps([0.0, 0.1, 0.3, 0.4], [1, 2, 3, 4], [0, 0, 0, 1])
    np.testing.assert_allclose(tw.dt, [0.1, 0.2, 0.1, 0.1])  # last: the median gap
    assert Twist.from_stamps([0.0, 0.5], [1, 2], [0, 0], last_dt=0.02).dt[-1] == 0.02


def test_twist_from_stamps_drops_commands_superseded_at_the_same_stamp():
    tw = Twist.from_stamps([0.0, 0.1, 0.1, 0.2], [1, 2, 3, 4], [0, 0, 0, 0])
    np.testing.assert_allclose(tw.t, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(tw.v, [1, 3, 4])  # the later of two equal stamps wins
    assert Twist.from_stamps([5.0], [1.0], [0.0]).dt[0] == 1.0
