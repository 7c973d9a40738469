"""Results as MCAP (``slamarena map … --mcap``, a config's ``mcap: true``): read back with rosbags, every message
checked against the outputs written beside it."""

from __future__ import annotations

import os
import textwrap

import numpy as np
import pytest
from bags import robot_bag
from checks import staged
from rich.console import Console

import slamarena
from slamarena.datasets.formats import tum
from slamarena.datasets.formats.bag_io import open_bag, read_topic
from slamarena.datasets.formats.ros_convert import yaw_of
from slamarena.experiments.cli_map import map_command
from slamarena.experiments.config import load_config
from slamarena.experiments.mcap_output import write_result_mcap
from slamarena.experiments.runner import run_experiment


def _topics(path):
    with open_bag(path) as reader:
        return {c.topic: read_topic(reader, c.topic) for c in reader.connections}


def _pose(p):
    q = p.orientation
    return np.array([p.position.x, p.position.y, yaw_of(np.array([q.x, q.y, q.z, q.w]))])


def test_map_on_a_bag_writes_an_mcap_with_every_pose_and_the_grid(tmp_path):
    import yaml

    written = robot_bag(tmp_path / "run.bag")
    out = tmp_path / "out"
    # a .bag path is short for bag:<path>; the 8-beam scans have 6 usable beams
    assert map_command(str(tmp_path / "run.bag"), params={"frontend": {"min_beams": 3}}, out=out, mcap=True) == 0
    traj = tum.read_trajectory(out / "trajectory.tum")
    np.testing.assert_allclose(traj.t, written["t_scan"])
    topics = _topics(out / "result.mcap")
    assert set(topics) == {"/tf", "/trajectory", "/map"}
    tf = topics["/tf"]
    assert len(tf) == len(traj)
    for k, m in enumerate(tf.messages):
        (ts,) = m.transforms
        assert (ts.header.frame_id, ts.child_frame_id) == ("map", "base_link")
        r, tr = ts.transform.rotation, ts.transform.translation
        got = [tr.x, tr.y, yaw_of(np.array([r.x, r.y, r.z, r.w]))]
        np.testing.assert_allclose(got, traj.poses[k], atol=1e-12)
    np.testing.assert_allclose(tf.header / 1.0, traj.t, atol=1e-9)
    (path,) = topics["/trajectory"].messages
    np.testing.assert_allclose([_pose(p.pose) for p in path.poses], traj.poses, atol=1e-12)
    (grid,) = topics["/map"].messages
    meta = yaml.safe_load((out / "map.yaml").read_text())
    assert grid.info.resolution == pytest.approx(meta["resolution"])
    np.testing.assert_allclose([grid.info.origin.position.x, grid.info.origin.position.y], meta["origin"][:2])
    data = np.asarray(grid.data).reshape(grid.info.height, grid.info.width)
    pgm = (out / "map.pgm").read_bytes()
    pixels = np.frombuffer(pgm[-grid.info.width * grid.info.height :], dtype=np.uint8).reshape(data.shape)[::-1]
    np.testing.assert_array_equal(data == 100, pixels == 0)  # occupied
    np.testing.assert_array_equal(data == 0, pixels == 254)  # free
    assert (data == 100).any() and (data == 0).any()


def test_landmarks_are_a_marker_array(tmp_path):
    seq = slamarena.load("sim:landmarks", n_landmarks=12, laps=1)
    est = slamarena.create("ekf_slam").run(seq)
    topics = _topics(write_result_mcap(tmp_path / "ekf.mcap", est))
    assert set(topics) == {"/tf", "/trajectory", "/landmarks"}
    (array,) = topics["/landmarks"].messages
    assert [m.id for m in array.markers] == est.landmark_ids.tolist()
    np.testing.assert_allclose([[m.pose.position.x, m.pose.position.y] for m in array.markers], est.landmarks)
    assert {(m.ns, m.type, m.header.frame_id) for m in array.markers} == {("landmarks", 2, "map")}
    assert len(topics["/tf"]) == len(est.t)


def test_a_config_with_mcap_writes_it_in_every_cell(tmp_path):
    path = tmp_path / "exp.yaml"
    path.write_text(
        textwrap.dedent("""
        name: mc
        seeds: 1
        mcap: true
        datasets:
          - name: sim:landmarks
            params: {n_landmarks: 8, laps: 1}
        estimators:
          - name: dead_reckoning
        metrics: [ate]
        figures: []
        """)
    )
    out = tmp_path / "out"
    assert run_experiment(load_config(path), out, console=Console(file=open(os.devnull, "w"))) == 0
    (cell,) = list((out / "runs").glob("*/*/*"))
    traj = tum.read_trajectory(cell / "trajectory.tum")
    (msg,) = _topics(cell / "result.mcap")["/trajectory"].messages
    np.testing.assert_allclose([_pose(p.pose) for p in msg.poses], traj.poses, atol=1e-12)


@pytest.mark.slow
@pytest.mark.realdata
def test_grid_slam_on_the_staged_aces_bag_end_to_end(tmp_path):
    staged("ros_bags/aces.clf2bag.bag")
    assert map_command("bag:aces", out=tmp_path, mcap=True) == 0
    traj = tum.read_trajectory(tmp_path / "trajectory.tum")
    assert len(traj) == 7374
    assert len(_topics(tmp_path / "result.mcap")["/tf"]) == 7374
