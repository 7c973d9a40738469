"""``slamarena map``: a hand-written CARMEN log through the whole command, outputs read back."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import interlace, make_sequence

from slamarena.datasets.formats import relations as relations_format
from slamarena.datasets.formats import tum
from slamarena.datasets.geometry import between
from slamarena.experiments.cli_map import map_command
from slamarena.mapping.occupancy_grid import load_map_server


@pytest.fixture(scope="module")
def carmen_log(tmp_path_factory):
    seq = make_sequence(n=50, seed=5)
    sc = seq.scans
    path = tmp_path_factory.mktemp("log") / "room.clf"
    t0 = 1000.0
    with open(path, "w") as fh:
        fh.write("# hand-made log of the test room\n")
        for k in range(len(sc.t)):
            r = " ".join(f"{v:.3f}" for v in sc.ranges[k])
            x, y, th = sc.pose[k]
            fh.write(
                f"FLASER {sc.ranges.shape[1]} {r} {x:.6f} {y:.6f} {th:.6f} {x:.6f} {y:.6f} {th:.6f} "
                f"{t0 + sc.t[k]:.6f} testhost {sc.t[k]:.6f}\n"
            )
    return path, seq, t0


def test_map_command_writes_trajectory_map_and_summary(carmen_log, tmp_path):
    path, seq, t0 = carmen_log
    truth = seq.ground_truth.poses
    rel = relations_format.Relations(
        t1=t0 + seq.scans.t[:-5],
        t2=t0 + seq.scans.t[5:],
        motion=np.column_stack(
            [between(truth[:-5], truth[5:])[:, :2], np.zeros((len(truth) - 5, 3)), between(truth[:-5], truth[5:])[:, 2]]
        ),
    )
    relations_format.write(tmp_path / "room.relations", rel)
    out = tmp_path / "out"
    assert (
        map_command(
            str(path), params={"frontend": {"matcher": "gauss_newton"}}, out=out, relations=tmp_path / "room.relations"
        )
        == 0
    )
    for name in ("trajectory.tum", "estimate.npz", "map.png", "map.pgm", "map.yaml", "summary.json"):
        assert (out / name).stat().st_size > 0, name
    traj = tum.read_trajectory(out / "trajectory.tum")
    assert len(traj) == len(seq.scans.t)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scans"] == len(seq.scans.t) and summary["real_time_factor"] > 0
    r = summary["relations"]
    assert r["used"] == len(truth) - 5 and r["trans_mean"] < 0.03 and r["rot_mean"] < 0.01
    ros, res, _ = load_map_server(out / "map.yaml")
    assert res == 0.05 and (ros == 100).sum() > 100


def test_map_command_rejects_bad_input_before_work(carmen_log, tmp_path):
    from slamarena.errors import UserError

    path, _, _ = carmen_log
    bad = tmp_path / "bad.clf"
    bad.write_text("FLASER 3 1.0 1.0\n")
    cases = [
        (dict(params={"frontend": {"matcher": "ndt"}}), "params.frontend.matcher"),
        (
            dict(params={"matcher": "ndt"}),
            "params.matcher: not a parameter of GridSLAMParams; did you mean params.frontend.matcher",
        ),
        (dict(method="ndt_slam"), "unknown mapping method 'ndt_slam'"),
        (dict(method="laser_slam", params={"submap_scans": 0}), "params.submap_scans"),
        (dict(relations=tmp_path / "missing.relations"), "missing.relations does not exist"),
    ]
    for kwargs, message in cases:
        with pytest.raises(UserError, match=message):
            map_command(str(path), out=tmp_path, **kwargs)
    with pytest.raises(UserError, match="neither a dataset name"):
        map_command(str(tmp_path / "no_such.clf"), out=tmp_path)
    with pytest.raises(UserError, match="bad.clf:1"):
        map_command(str(bad), out=tmp_path)
    assert not (tmp_path / "summary.json").exists()


def test_map_command_with_laser_slam_writes_the_pose_graph_and_loop_list(carmen_log, tmp_path):
    from slamarena.datasets.formats import g2o

    path, seq, _ = carmen_log
    out = tmp_path / "graph"
    assert map_command(str(path), method="laser_slam", params={"loop": {"search_every": 1}}, out=out) == 0
    graph = g2o.read(out / "pose_graph.g2o")
    summary = json.loads((out / "summary.json").read_text())
    assert graph.n_nodes == summary["nodes"] and summary["method"] == "laser_slam"
    lines = (out / "loop_closures.csv").read_text().splitlines()
    assert lines[0].startswith("node,submap") and len(lines) - 1 == summary["loop_candidates"]
    # every candidate is accepted or rejected by one named test, and the run counts them
    assert "rejected_by" in lines[0].split(",") and summary["loop_verify"] == "gnc"
    assert sum(summary["loop_rejected_by"].values()) == summary["loop_rejected"]
    assert summary["loop_closures"] + summary["loop_rejected"] == summary["loop_candidates"]
    assert len(tum.read_trajectory(out / "trajectory.tum")) == len(seq.scans.t)


def test_map_command_on_an_interlaced_robotlaser_log(tmp_path):
    """The room scanned like fr-clinic (four layouts ¼ step apart, 181/180 beams) as ROBOTLASER1
    messages: read into one stream and mapped with each scan's own angles."""
    seq = make_sequence(n=60, seed=6)
    sc = interlace(seq)
    path = tmp_path / "interlaced.clf"
    with open(path, "w") as fh:
        for k in range(len(sc)):
            r, a = sc.beams(k)
            x, y, th = sc.pose[k]
            pose = f"{x:.6f} {y:.6f} {th:.6f}"
            fh.write(
                f"ROBOTLASER1 0 {a[0]:.6f} 3.141593 {a[1] - a[0]:.6f} {sc.max_range:.1f} 0.01 0 {r.size} "
                f"{' '.join(f'{v:.3f}' for v in r)} 0 "
                f"{pose} {pose} 0 0 0 0 0 {1000.0 + sc.t[k]:.6f} testhost {sc.t[k]:.6f}\n"
            )
    truth = seq.ground_truth.poses
    rel = relations_format.Relations(
        t1=1000.0 + sc.t[:-1],
        t2=1000.0 + sc.t[1:],
        motion=np.column_stack(
            [between(truth[:-1], truth[1:])[:, :2], np.zeros((len(truth) - 1, 3)), between(truth[:-1], truth[1:])[:, 2]]
        ),
    )
    relations_format.write(tmp_path / "room.relations", rel)
    out = tmp_path / "out"
    assert map_command(str(path), out=out, relations=tmp_path / "room.relations") == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scans"] == 60 and summary["beam_layouts"] == 4 and summary["bad_beams"] == 0
    assert summary["relations"]["trans_mean"] < 0.02 and summary["relations"]["rot_mean"] < 0.004


def test_param_pairs_nest_by_their_dotted_paths():
    from slamarena.errors import UserError
    from slamarena.experiments.cli_map import parse_params

    assert parse_params(["loop.level=2", "loop.voxel=0.2", "pyramid.cells.hit_guard=1", "submap_scans=30"]) == {
        "loop": {"level": 2, "voxel": 0.2},
        "pyramid": {"cells": {"hit_guard": 1}},
        "submap_scans": 30,
    }
    for bad in (["loop=1", "loop.level=2"], ["loop.level=2", "loop=1"], ["loop..level=2"], ["level"]):
        with pytest.raises(UserError, match="--param"):
            parse_params(bad)


def test_map_command_reports_the_one_off_compilation_apart(carmen_log, tmp_path):
    """With a cold numba cache the first scan compiles the kernels: ms/scan and the real-time factor leave it out,
    and the summary and the console line state it separately."""
    import os
    import subprocess
    import sys

    path, _, _ = carmen_log
    out = tmp_path / "out"
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "from slamarena.experiments.cli import main; main()",
            "map",
            str(path),
            "--out",
            str(out),
        ],
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "COLUMNS": "400"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    compile_s, wall, K = summary["compile_s"], summary["wall_s"], summary["scans"]
    assert 0 < compile_s < wall
    assert summary["per_scan_ms"]["mean"] == pytest.approx(1e3 * (wall - compile_s) / K)
    assert summary["per_scan_ms"]["mean_with_compilation"] == pytest.approx(1e3 * wall / K)
    duration = summary["log_duration_s"]
    assert summary["real_time_factor"] == pytest.approx(duration / (wall - compile_s))
    assert summary["real_time_factor_with_compilation"] == pytest.approx(duration / wall)
    assert f"{compile_s:.1f} s compiling numba kernels" in done.stdout
