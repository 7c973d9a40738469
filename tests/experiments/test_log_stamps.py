"""Trajectories are written at the log's own stamps: where the CARMEN reader made a stepping-back stamp increase,
``trajectory.tum`` carries the original stamp (rows sorted by it, a header comment naming the adjusted ones), evo
reads it, a relations file finds every pose by its stamps, and ``slamarena eval`` maps the stamps back."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from checks import load_staged
from evo.tools import file_interface

from slamarena.datasets.formats import carmen, relations, tum
from slamarena.datasets.geometry import between
from slamarena.datasets.log_stamps import log_stamps
from slamarena.experiments.cli_eval import evaluate_file
from slamarena.experiments.results import write_trajectory_tum


def _log(tmp_path, back: float):
    """20 ODOM + FLASER pairs at 5 Hz, 0.1 m and 0.05 rad per step; scan 5's stamp ``back`` s before scan 4's."""
    lines = []
    for k in range(20):
        t, x, th = 100 + 0.2 * k, 0.1 * k, 0.05 * k
        ts = t + 0.1 if k != 5 else 100 + 0.2 * 4 + 0.1 - back
        lines += [
            f"ODOM {x:.2f} 0 {th:.2f} 0 0 0 {t:.3f} host 0",
            f"FLASER 4 1 2 3 4 {x:.2f} 0 {th:.2f} {x:.2f} 0 {th:.2f} {ts:.3f} host 0",
        ]
    path = tmp_path / "log.clf"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_trajectory_carries_the_original_stamps_sorted_and_named(tmp_path):
    s = carmen.read(_log(tmp_path, back=0.05))
    ipc = s.meta["scan_ipc_timestamp"]
    assert s.meta["time_adjusted_messages"] == 1 and (np.diff(ipc) < 0).sum() == 1
    write_trajectory_tum(tmp_path / "trajectory.tum", s.scans.t, s.scans.pose, s)

    traj = file_interface.read_tum_trajectory_file(str(tmp_path / "trajectory.tum"))
    assert traj.check()[0], traj.check()[1]  # evo: stamps ascending, quaternions unit
    order = np.argsort(ipc)
    np.testing.assert_array_equal(traj.timestamps, ipc[order])  # the reader's original stamps, exactly
    ours = tum.read_trajectory(tmp_path / "trajectory.tum")
    np.testing.assert_allclose(ours.poses, s.scans.pose[order], atol=1e-12)  # each pose at its own scan's stamp
    header = (tmp_path / "trajectory.tum").read_text().splitlines()[:3]
    assert "adjusted 1 of 20" in " ".join(header) and "1 scans step back" in " ".join(header)

    # a relations file at the original stamps, including the scan that steps back, finds every pose ...
    k = np.array([[3, 5], [5, 6], [4, 5], [0, 19]])
    rel = relations.Relations(ipc[k[:, 0]], ipc[k[:, 1]], np.zeros((len(k), 6)))
    rel.motion[:, [0, 1, 5]] = between(s.scans.pose[k[:, 0]], s.scans.pose[k[:, 1]])
    relations.write(tmp_path / "log.relations", rel)
    # ... and `slamarena eval` maps the written stamps back to the Sequence's times: the odometry scores zero
    result = evaluate_file(
        tmp_path / "trajectory.tum",
        f"carmen:{tmp_path / 'log.clf'}",
        ["relations"],
        {"relations": {"file": str(tmp_path / "log.relations"), "tolerance": 0.0}},
    )
    scores = result["metrics"]["relations"]
    assert scores["used"] == len(k) and scores["dropped"] == 0 and scores["trans_mean"] < 1e-9, scores


def test_a_log_whose_stamps_the_reader_kept_is_written_unchanged(tmp_path):
    s = carmen.read(_log(tmp_path, back=-0.1))  # scan 5 at its regular stamp
    assert s.meta["time_adjusted_messages"] == 0 and log_stamps(s, s.scans.t) is None
    write_trajectory_tum(tmp_path / "trajectory.tum", s.scans.t, s.scans.pose, s)
    assert "adjusted" not in (tmp_path / "trajectory.tum").read_text()
    np.testing.assert_array_equal(tum.read(tmp_path / "trajectory.tum").t, s.scans.t)


def test_repeating_original_stamps_are_not_written_and_the_file_says_so(tmp_path):
    s = carmen.read(_log(tmp_path, back=0.05))
    ipc = s.meta["scan_ipc_timestamp"].copy()
    ipc[6] = ipc[7]  # two scans share a stamp: no strictly increasing order of the originals
    s = dataclasses.replace(s, meta={**s.meta, "scan_ipc_timestamp": ipc})
    write_trajectory_tum(tmp_path / "trajectory.tum", s.scans.t, s.scans.pose, s)
    assert "the reader's times" in (tmp_path / "trajectory.tum").read_text()
    np.testing.assert_array_equal(tum.read(tmp_path / "trajectory.tum").t, s.scans.t)


@pytest.mark.realdata
def test_intel_relations_find_every_pose_by_the_written_stamps(tmp_path):
    s = load_staged("carmen:intel")
    write_trajectory_tum(tmp_path / "trajectory.tum", s.scans.t, s.scans.pose, s)
    written = file_interface.read_tum_trajectory_file(str(tmp_path / "trajectory.tum")).timestamps
    np.testing.assert_array_equal(written, np.sort(s.meta["scan_ipc_timestamp"]))
    rel = relations.read(s.meta["relations"])
    stamps = np.concatenate([rel.t1, rel.t2])
    k = np.clip(np.searchsorted(written, stamps), 0, len(written) - 1)
    assert len(rel) == 2984 and np.all(np.abs(written[k] - stamps) < 1e-6)  # every pair finds both its poses
