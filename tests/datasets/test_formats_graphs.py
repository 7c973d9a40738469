"""g2o, TORO and iSAM graph readers on the staged files; g2o write round trip; malformed files."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged, staged

from slamarena.datasets import DataFormatError, load
from slamarena.datasets.formats import g2o, isam, toro
from slamarena.datasets.geometry import compose

pytestmark = pytest.mark.realdata


def test_noisy_toy_graph_contents():
    g = load_staged("g2o:noisyToyGraph")
    assert g.node_ids.tolist() == [0, 1, 2, 3] and g.n_edges == 5
    assert np.allclose(g.poses[1], [0.774115, 1.183389, 1.576173])
    assert np.allclose(g.poses[3], [-1.605649, 0.993891, -1.561134])
    assert (g.edge_i.tolist(), g.edge_j.tolist()) == ([0, 1, 2, 2, 0], [1, 2, 3, 0, 3])
    assert np.allclose(g.edge_z[3], [0.303492, 1.865011, -3.113898])
    assert np.allclose(g.edge_information, np.eye(3))
    assert g.summary()["loop_edges"] == 2


@pytest.mark.parametrize(
    "name, nodes, edges, odometry, has_vertices",
    [
        ("intel", 1728, 2512, 1727, True),
        ("MIT", 808, 827, 807, True),
        ("CSAIL", 1045, 1172, 1044, False),
        ("manhattan", 3500, 5453, 3499, False),
        ("city10000", 10000, 20687, 9999, True),
    ],
)
def test_sesync_2d_counts(name, nodes, edges, odometry, has_vertices):
    g = load_staged(f"g2o:{name}")
    assert (g.n_nodes, g.n_edges, int(g.odometry_mask().sum())) == (nodes, edges, odometry)
    assert (g.poses is not None) == has_vertices
    assert g.initial_poses().shape == (nodes, 3)


def test_intel_g2o_first_records():
    g = load_staged("g2o:intel")
    assert np.allclose(g.poses[1], [0.144012, -0.004462, -0.017453])
    I = g.edge_information[0]
    assert np.allclose(I, [[115.187, -9.86523, -7.085], [-9.86523, 347.418, 185.36], [-7.085, 185.36, 224.616]])


def test_parking_garage_3d():
    g = load_staged("g2o:parking-garage")
    assert g.dim == 3 and (g.n_nodes, g.n_edges) == (1661, 6275)
    assert np.allclose(g.edge_z[0], [4.15448, -0.0665288, 0.000389663, -0.0107791, 0.00867285, -0.00190021, 0.999902])
    I = g.edge_information[0]
    assert np.allclose(np.diag(I), [1, 1, 1, 4.00073, 3.9997, 4.00118])
    assert I[3, 4] == I[4, 3] == -0.000375887 and I[3, 5] == 0.0691425


def test_manhattan_ground_truth_from_isam_noise_free_file():
    g = load_staged("g2o:manhattan")
    assert g.true_poses.shape == (3500, 3) and np.allclose(g.true_poses[:3], [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
    # the noisy odometry stays close to the truth over the first steps
    assert np.abs(g.chain_initialisation()[:20, :2] - g.true_poses[:20, :2]).max() < 0.5


def test_isam_sqrt_information_and_ground_truth():
    g = load_staged("isam:cityTrees10000")
    assert (g.n_nodes, g.n_edges, g.landmark_pose.size, np.unique(g.landmark_id).size) == (10000, 9999, 4443, 100)
    assert np.allclose(g.edge_information[0], np.diag([2500.0, 2500.0, 10000.0]))  # R = diag(50, 50, 100)
    assert np.allclose(g.landmark_information[0], np.eye(2) * 100.0)
    # true landmark = true pose ⊕ noise-free measurement, for EVERY observation (not only the first)
    truth = g.true_landmarks
    rec = isam.read_records(staged("isam_data/groundtruth/cityTrees10000_groundtruth.txt"))
    seen_from = g.true_poses[g.index_of(rec.lm_pose)]
    predicted = compose(seen_from, np.column_stack([rec.lm_z, np.zeros(len(rec.lm_z))]))[:, :2]
    expected = truth.xy[np.searchsorted(truth.ids, rec.lm_id)]
    # agreement to the printing precision of the noise-free file (6 digits: e.g. -3.14159 for π),
    # which accumulates to about 1.5 cm along the 10000-pose chain
    assert np.abs(predicted[:40] - expected[:40]).max() < 1e-4
    assert np.abs(predicted - expected).max() < 0.02


def test_manhattan_olson_loop_closures_consistent_with_truth():
    g = load_staged("isam:manhattanOlson3500")
    assert (g.n_nodes, g.n_edges, int((~g.odometry_mask()).sum())) == (3500, 5598, 2099)
    assert np.allclose(g.edge_information[0], np.eye(3) * 44.72135955**2)


def test_w20000_is_isam_convention():
    g = load_staged("isam:w20000")
    assert (g.n_nodes, g.n_edges) == (20061, 26831)
    assert np.allclose(g.edge_information[0], np.diag([3.16228**2, 3.16228**2, 25.0]))


def test_isam_noise_option_as_a_params_model_or_keyword():
    path = staged("isam_data/manhattanOlson3500.txt")
    given = isam.load({"graph": path}, "m3500", params=isam.IsamSource(path=str(path), noise="information"))
    keywords = load(f"isam:{path}", noise="information")
    assert isam.load.Params is isam.IsamSource and given.meta["noise_convention"] == "information"
    np.testing.assert_allclose(given.edge_information[0], np.eye(3) * 44.72135955)  # the R columns read as Λ itself
    np.testing.assert_array_equal(given.edge_information, keywords.edge_information)


def test_toro_w100_and_example_graph():
    w = load_staged("g2o:w100")
    assert (w.n_nodes, w.n_edges, w.meta["equivalence_count"]) == (100, 300, 40)
    assert w.meta["equivalences"][0] == [21, 1]
    assert (w.edge_i[0], w.edge_j[0]) == (1, 0) and np.allclose(w.edge_information[0], np.eye(3))
    e = load_staged("g2o:example")
    assert (e.n_nodes, e.n_edges, e.landmark_pose.size) == (95, 94, 422) and e.landmark_kind == "bearing_range"
    assert np.allclose(e.landmark_z[0], [0.185182458717, 9.13212526936])
    assert np.allclose(e.landmark_information[0], np.diag([1 / 0.0349**2, 1 / 0.1**2]))


def test_toro_information_order(tmp_path):
    f = tmp_path / "t.graph"
    f.write_text("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 2 3 11 12 22 33 13 23\n")
    I = toro.read(f).edge_information[0]
    assert I.tolist() == [[11, 12, 13], [12, 22, 23], [13, 23, 33]]


def test_g2o_round_trip(tmp_path):
    g = load_staged("g2o:intel")
    g2o.write(tmp_path / "intel.g2o", g)
    back = g2o.read(tmp_path / "intel.g2o")
    for key in ("node_ids", "edge_i", "edge_j", "edge_z", "edge_information", "poses"):
        assert np.array_equal(getattr(back, key), getattr(g, key)), key


def test_g2o_source_file_names_the_file_only_for_its_unedited_content(tmp_path):
    """``g2o.source_file``: the file a graph was read from while the graph holds exactly its content and the file is
    unchanged (the GTSAM pose-graph optimiser then lets GTSAM's reader build its graph from it); None otherwise."""
    import dataclasses
    import os

    from slamarena.datasets.posegraph import PoseGraph

    path = tmp_path / "t.g2o"
    path.write_text("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 10 0 0 10 0 20\n")
    graph = g2o.read(path)
    assert g2o.source_file(graph) == path
    assert g2o.source_file(g2o.read(path)) == path and g2o.fingerprint(g2o.read(path)) == g2o.fingerprint(graph)
    same = PoseGraph(**{**graph.__dict__, "name": "renamed"})
    assert g2o.source_file(same) == path  # the same arrays
    moved = dataclasses.replace(graph, edge_z=graph.edge_z + [[0.0, 0.0, 1e-12]])  # keeps the meta, not the content
    assert g2o.source_file(moved) is None
    assert g2o.source_file(PoseGraph(**{**graph.__dict__, "meta": {}})) is None
    graph.poses[1, 0] = 2.0  # edited in place
    assert g2o.source_file(graph) is None
    graph = g2o.read(path)
    os.utime(path, ns=(0, 0))  # the file changed since it was read
    assert g2o.source_file(graph) is None
    path.unlink()
    assert g2o.source_file(graph) is None
    toro_file = tmp_path / "t.graph"
    toro_file.write_text("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 0 10 20 0 0\n")
    assert g2o.source_file(toro.read(toro_file)) is None


def test_g2o_round_trip_with_landmarks(tmp_path):
    g = load_staged("victoria_park", as_graph=True)
    g2o.write(tmp_path / "vp.g2o", g)
    back = g2o.read(tmp_path / "vp.g2o")
    assert np.array_equal(back.landmark_id, g.landmark_id) and np.array_equal(back.landmark_z, g.landmark_z)
    assert np.array_equal(back.landmark_information, g.landmark_information)
    assert np.allclose(back.poses, g.chain_initialisation())


@pytest.mark.parametrize(
    "reader, text, line, fragment",
    [
        (g2o.read, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n", 3, "11 numeric fields"),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 x 0 0\n", 2, "numeric"),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nEDGE_FOO 0 1\n", 2, "g2o record"),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 7 1 0 0 1 0 0 1 0 1\n", 2, "declared vertices"),
        (g2o.read, "VERTEX_SE2 0.5 0 0 0\n", 1, "integer ids"),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 0 0\nEDGE_SE2 0 1 nan 0 0 1 0 0 1 0 1\n", 3, "finite"),
        (toro.read, "VERTEX2 0 0 0 0\nVERTEX2 1 0 0 inf\n", 2, "finite"),
        (toro.read, "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 0 2 0 0\n", 3, "also declared on line 1"),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 1 2 0 0\n", 3, "also declared on line 2"),
        (isam.read, "ODOMETRY 0 1 0 0 0 nan 0 0 1 0 1\n", 1, "finite"),
        (toro.read, "VERTEX2 0 0 0 0\nEDGE2 0 0 1 0 0 1 0 1 1 0\n", 2, "11 numeric fields"),
        (isam.read, "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nPOINT 3\n", 2, "record of type"),
        (isam.read, "ODOMETRY 0 1 1 0 0 1 0 0 1 0 0\n", 1, "positive-definite"),
        # an information matrix with smallest eigenvalue −100 (iSAM's check, shared): pose edges, xy landmark edges, TORO
        (
            g2o.read,
            "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 -100\n",
            3,
            "positive-definite",
        ),
        (g2o.read, "VERTEX_SE2 0 0 0 0\nEDGE_SE2_XY 0 5 1 0 1 0 -100\n", 2, "positive-definite landmark"),
        (toro.read, "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 1 0 1 -100 0 0\n", 3, "positive-definite"),
        (isam.read, "EDGE2 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 0 1 1 1 0\n", 2, "7 numeric fields"),
    ],
)
def test_malformed_graphs(tmp_path, reader, text, line, fragment):
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(DataFormatError) as err:
        reader(f)
    assert err.value.line == line and str(f) in str(err.value) and fragment in str(err.value)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    """A g2o file saved "with BOM" reads as without it (the mark was rejected at line 1)."""
    text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
    (tmp_path / "plain.g2o").write_text(text)
    (tmp_path / "bom.g2o").write_bytes(b"\xef\xbb\xbf" + text.encode())
    plain, bom = g2o.read(tmp_path / "plain.g2o"), g2o.read(tmp_path / "bom.g2o")
    np.testing.assert_array_equal(bom.node_ids, plain.node_ids)
    np.testing.assert_array_equal(bom.edge_information, plain.edge_information)
