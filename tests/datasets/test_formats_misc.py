"""Relations, TUM and KITTI .bin: staged files, round trips, malformed input."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import relations, tum


def test_relations_round_trip_and_tagged_lines(tmp_path, rng):
    rel = relations.Relations(t1=rng.uniform(0, 1e9, 20), t2=rng.uniform(0, 1e9, 20), motion=rng.normal(size=(20, 6)))
    relations.write(tmp_path / "r.relations", rel)
    back = relations.read(tmp_path / "r.relations")
    assert (
        np.array_equal(back.t1, rel.t1) and np.array_equal(back.t2, rel.t2) and np.array_equal(back.motion, rel.motion)
    )
    assert np.array_equal(back.se2, rel.motion[:, [0, 1, 5]])
    (tmp_path / "tagged").write_text("FLASER 1.5 2.5 0.1 0 0 0 0 0.2\nFLASER 2.5 3.5 0.1 0 0 0 0 0.3\n")
    tagged = relations.read(tmp_path / "tagged")
    assert tagged.t1.tolist() == [1.5, 2.5] and tagged.motion[1, 5] == 0.3


def test_relations_malformed(tmp_path):
    (tmp_path / "bad").write_text("1 2 0 0 0 0 0 0\n3 4 0 0 0 0 0\n")
    with pytest.raises(DataFormatError) as err:
        relations.read(tmp_path / "bad")
    assert err.value.line == 2 and "8 numeric fields" in str(err.value)


def test_tum_round_trip_and_quaternion_convention(tmp_path, rng):
    t = np.cumsum(rng.uniform(0.01, 0.1, 50))
    poses = np.column_stack([rng.normal(size=(50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    tum.write(tmp_path / "traj.tum", t, poses)
    raw = tum.read(tmp_path / "traj.tum")
    assert np.allclose(raw.quat[:, :2], 0) and np.allclose(raw.quat[:, 2], np.sin(poses[:, 2] / 2))
    back = tum.read_trajectory(tmp_path / "traj.tum")
    assert np.array_equal(back.t, t) and np.allclose(back.poses, poses, atol=1e-12)
    first = (tmp_path / "traj.tum").read_text().splitlines()[1].split()
    assert len(first) == 8 and float(first[3]) == 0.0  # timestamp x y z qx qy qz qw


def test_tum_rejects_tilted_rotation_and_bad_lines(tmp_path):
    (tmp_path / "a.tum").write_text("0 0 0 0 0.3 0 0 0.95\n")
    with pytest.raises(ValueError, match="rotation about z"):
        tum.read_trajectory(tmp_path / "a.tum")
    (tmp_path / "b.tum").write_text("# c\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n")
    with pytest.raises(DataFormatError) as err:
        tum.read(tmp_path / "b.tum")
    assert err.value.line == 3
    (tmp_path / "c.tum").write_text("1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n")
    with pytest.raises(DataFormatError, match="non-decreasing"):
        tum.read(tmp_path / "c.tum")
