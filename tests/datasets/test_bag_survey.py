"""``slamarena data info bag:…``: topics, counts, rates, stamp sources and stamp anomalies of a bag."""

from __future__ import annotations

import numpy as np
import pytest
from bags import robot_bag
from checks import staged
from typer.testing import CliRunner

from slamarena.datasets.formats.bag_survey import GAP_FACTOR, stamp_anomalies, survey
from slamarena.experiments.cli import app


def test_anomalies_of_hand_made_stamps():
    ns = 1_000_000_000
    real = (np.arange(20) * 0.1 * ns + np.random.default_rng(1).integers(-5000, 5000, 20)).astype(np.int64)
    assert stamp_anomalies(real) == {"out_of_order": 0, "duplicates": 0, "gaps": 0, "synthetic": False}
    synthetic = np.arange(20, dtype=np.int64) * ns // 10 + 10**18
    assert stamp_anomalies(synthetic)["synthetic"]
    odd = real.copy()
    odd[5] = odd[4]  # a duplicate
    odd[8] = odd[7] - 1  # one stepping back
    odd[12:] += int(GAP_FACTOR * 0.1 * ns * 2)  # a gap of 10 steps
    a = stamp_anomalies(odd)
    assert (a["out_of_order"], a["first_out_of_order_index"], a["duplicates"], a["gaps"]) == (1, 8, 1, 1)
    assert a["longest_gap_s"] == pytest.approx(1.1, abs=1e-5)


def test_survey_of_a_written_bag(tmp_path):
    robot_bag(tmp_path / "run.mcap", "mcap")
    s = survey(tmp_path / "run.mcap")
    assert (s["kind"], s["storage"]) == ("ROS 2", "MCAP")
    scan = s["topics"]["/scan"]
    assert (scan["type"], scan["count"], scan["stamps"]) == ("sensor_msgs/msg/LaserScan", 5, "header")
    assert scan["rate_hz"] == pytest.approx(10.0) and scan["span_s"] == pytest.approx(0.4)
    assert scan["anomalies"]["header_equals_receive"] is False  # received 50 ms after stamping
    assert s["topics"]["/cmd_vel"]["stamps"] == "receive"  # a Twist has no header
    assert s["duration_s"] == pytest.approx(0.65)  # /tf_static stamped 9.9 s to the last /cmd_vel received 10.55 s


def test_data_info_lists_topics_then_the_readers_refusal(tmp_path):
    robot_bag(tmp_path / "back.bag", scan_stamps=[10.0, 10.1, 10.05, 10.3, 10.4])
    out = CliRunner().invoke(app, ["data", "info", f"bag:{tmp_path / 'back.bag'}"], env={"COLUMNS": "250"})
    assert out.exit_code == 2
    assert "/scan" in out.output and "1 out of order (first: message 2)" in out.output
    assert "sensor_msgs/msg/LaserScan" in out.output and "nav_msgs/msg/Odometry" in out.output
    assert "topic /scan, message 2: expected non-decreasing header stamps" in " ".join(out.output.split())


@pytest.mark.realdata
def test_data_info_on_the_staged_aces_bag_calls_its_stamps_synthetic():
    staged("ros_bags/aces.clf2bag.bag")
    out = CliRunner().invoke(app, ["data", "info", "bag:aces"], env={"COLUMNS": "250"})
    assert out.exit_code == 0, out.output
    for topic in ("/scan", "/odom", "/tf", "/tf_static"):
        assert topic in out.output
    assert out.output.count("synthetic stamps?") == 3 and "7374" in out.output and "737.300" in out.output
    assert '"scans": 7374' not in out.output and '"count": 7374' in out.output  # then the Sequence's summary
