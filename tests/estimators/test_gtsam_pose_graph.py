"""Pose-graph optimisation: GTSAM's noisyToyGraph, constructed graphs with a known optimum, landmarks, robustness."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

gtsam = pytest.importorskip("gtsam")

from checks import staged  # noqa: E402

from slamarena.datasets.formats import g2o  # noqa: E402
from slamarena.datasets.geometry import accumulate, between, compose, inverse, transform_points, wrap_angle  # noqa: E402
from slamarena.datasets.posegraph import PoseGraph  # noqa: E402
from slamarena.datasets.sim.landmarks import simulate  # noqa: E402
from slamarena.estimators.gtsam_smoother import BatchSmoother, PoseGraphOptimizer  # noqa: E402
from slamarena.estimators.gtsam_smoother.graph import X  # noqa: E402
from slamarena.estimators.gtsam_smoother.pose_graph import build_pose_graph  # noqa: E402


def _angle_aware_diff(a, b):
    d = np.asarray(a) - np.asarray(b)
    d[:, 2] = wrap_angle(d[:, 2])
    return d


@pytest.mark.parametrize("initial", ["file", "chain"])
def test_noisy_toy_graph_reaches_gtsams_reference(initial):
    """optimizedNoisyToyGraph holds GTSAM's LAGO answer, which GTSAM's own test compares at 1e-2; the
    nonlinear optimum must agree to that and have an error no larger than the reference poses'."""
    graph = g2o.read(staged("gtsam_examples_data/noisyToyGraph.txt"))
    expected = g2o.read(staged("gtsam_examples_data/optimizedNoisyToyGraph.txt"))
    est = PoseGraphOptimizer(initial=initial, covariances=True).run(graph)
    assert np.abs(_angle_aware_diff(est.poses, expected.poses)).max() < 1e-2
    factors, _ = build_pose_graph(graph)
    reference = gtsam.Values()
    for i, p in zip(expected.node_ids, expected.poses):
        reference.insert(X(i), gtsam.Pose2(*p))
    assert est.diagnostics["final_error"] <= factors.error(reference)
    assert est.diagnostics["final_error"] < est.diagnostics["initial_error"]
    assert est.diagnostics["final_error"] == pytest.approx(0.068343, abs=2e-6)
    assert est.pose_cov.shape == (4, 3, 3) and np.all(np.linalg.eigvalsh(est.pose_cov[1:]) > 0)


def _square_loop(n_side: int = 5, laps: int = 2):
    step = np.array([1.0, 0.0, 0.0])
    turn = np.array([1.0, 0.0, np.pi / 2])
    deltas = np.array([turn if (k + 1) % n_side == 0 else step for k in range(4 * n_side * laps)])
    return accumulate(np.zeros(3), deltas)


def test_noise_free_graph_with_loop_closures_recovers_truth_from_a_bad_start():
    truth = _square_loop()
    n = len(truth)
    i = np.arange(n - 1)
    loops_i = np.arange(0, n - 20)
    ei = np.concatenate([i, loops_i])
    ej = np.concatenate([i + 1, loops_i + 20])
    z = between(truth[ei], truth[ej])
    info = np.broadcast_to(np.diag([100.0, 100.0, 400.0]), (ei.size, 3, 3))
    rng = np.random.default_rng(1)
    start = truth + rng.normal(0, [0.3, 0.3, 0.1], truth.shape)
    start[0] = truth[0]
    graph = PoseGraph(
        name="square", node_ids=np.arange(n), edge_i=ei, edge_j=ej, edge_z=z, edge_information=info, poses=start
    )
    for optimizer in ("lm", "gauss_newton", "dogleg"):
        est = PoseGraphOptimizer(optimizer=optimizer).run(graph)
        assert np.abs(_angle_aware_diff(est.poses, truth)).max() < 1e-6, optimizer
        assert est.diagnostics["final_error"] < 1e-9
    chain = PoseGraphOptimizer(initial="chain").run(graph)
    assert np.abs(_angle_aware_diff(chain.poses, truth)).max() < 1e-6
    assert chain.meta["initial"] == "chain" and chain.meta["params"]["initial"] == "chain"


def test_xy_landmark_edges_are_points_in_the_robot_frame():
    truth = _square_loop(laps=1)
    n = len(truth)
    landmarks = np.array([[2.0, 2.0], [-1.0, 3.0], [5.0, -1.0]])
    pose, lid = np.meshgrid(np.arange(0, n, 2), np.arange(3), indexing="ij")
    pose, lid = pose.ravel(), lid.ravel()
    z = transform_points(inverse(truth[pose]), landmarks[lid])  # each landmark in the frame of its robot pose
    i = np.arange(n - 1)
    graph = PoseGraph(
        name="landmarks",
        node_ids=np.arange(n),
        edge_i=i,
        edge_j=i + 1,
        edge_z=between(truth[i], truth[i + 1]),
        edge_information=np.broadcast_to(np.eye(3) * 10.0, (n - 1, 3, 3)),
        poses=truth + np.random.default_rng(2).normal(0, 0.2, truth.shape) * (np.arange(n) > 0)[:, None],
        landmark_pose=pose,
        landmark_id=lid + 100,
        landmark_z=z,
        landmark_information=np.broadcast_to(np.eye(2) * 50.0, (pose.size, 2, 2)),
    )
    est = PoseGraphOptimizer(covariances=True).run(graph)
    np.testing.assert_array_equal(est.landmark_ids, [100, 101, 102])
    np.testing.assert_allclose(est.landmarks, landmarks, atol=1e-6)
    assert np.abs(_angle_aware_diff(est.poses, truth)).max() < 1e-6
    assert est.landmark_cov.shape == (3, 2, 2)


def test_robust_kernel_rejects_a_false_loop_closure():
    truth = _square_loop()
    n = len(truth)
    rng = np.random.default_rng(4)
    i = np.arange(n - 1)
    z = compose(between(truth[i], truth[i + 1]), rng.normal(0, [0.02, 0.02, 0.01], (n - 1, 3)))
    loops_i = np.arange(0, n - 20, 3)
    zl = between(truth[loops_i], truth[loops_i + 20])
    ei, ej = np.concatenate([i, loops_i, [3]]), np.concatenate([i + 1, loops_i + 20, [30]])
    zz = np.vstack([z, zl, [[5.0, -4.0, 2.0]]])  # one false loop closure
    info = np.broadcast_to(np.diag([2500.0, 2500.0, 1e4]), (ei.size, 3, 3))
    graph = PoseGraph(name="false-loop", node_ids=np.arange(n), edge_i=ei, edge_j=ej, edge_z=zz, edge_information=info)
    plain = PoseGraphOptimizer().run(graph)
    robust = PoseGraphOptimizer(robust="cauchy", robust_k=1.0).run(graph)
    err = lambda e: np.abs(_angle_aware_diff(e.poses, truth)[:, :2]).max()  # noqa: E731
    assert err(robust) < 0.2 and err(plain) > 3 * err(robust)


def test_sequence_input_is_solved_as_the_batch_smoother():
    seq = simulate(seed=5, n_landmarks=20, laps=1)
    a = PoseGraphOptimizer().run(seq)
    b = BatchSmoother(covariances=False, relative_error_tol=1e-8, absolute_error_tol=1e-8).run(seq)
    assert a.method == "gtsam_pose_graph"
    np.testing.assert_allclose(a.poses, b.poses, atol=1e-9)
    assert a.meta["params"] == b.meta["params"]  # the optimiser, kernel and covariance settings are passed on


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="initial"):
        PoseGraphOptimizer(initial="random")
    with pytest.raises(TypeError):
        PoseGraphOptimizer().run(np.zeros(3))


def test_parameters_are_one_model():
    with pytest.raises(ValidationError, match="anchor_sigma"):
        PoseGraphOptimizer(anchor_sigma=0.0)
    with pytest.raises(ValidationError, match="max_iter"):
        PoseGraphOptimizer(max_iter=10)  # a misspelt parameter is an error, never ignored
    given = dict(optimizer="gauss_newton", robust="cauchy", robust_k=1.0, covariances=True)
    assert PoseGraphOptimizer(PoseGraphOptimizer.Params(**given)).params == PoseGraphOptimizer(**given).params
    # the optimiser's settings are the batch smoother's fields; only the tolerances' defaults differ
    assert PoseGraphOptimizer().params.relative_error_tol == 1e-8 and BatchSmoother().params.relative_error_tol == 1e-10


# ---------------------------------------------------------------------------- the graph built without per-factor churn
def test_symbols_are_gtsams_keys():
    from slamarena.estimators.gtsam_smoother.graph import L, symbols

    ids = np.array([0, 7, 123456, 2**40])
    assert symbols("x", ids) == [X(i) for i in ids] and symbols("l", ids) == [L(i) for i in ids]


def test_one_noise_model_per_distinct_information_and_kernel():
    from slamarena.estimators.gtsam_smoother.graph import RobustKernelParams, information_models
    from slamarena.robust import information_model

    A, B = np.diag([4.0, 9.0, 16.0]), np.array([[10.0, 1.0, 0.0], [1.0, 20.0, 2.0], [0.0, 2.0, 30.0]])
    infos = np.stack([A, B, A, A, B])
    loop = np.array([False, False, True, False, False])
    kernel = RobustKernelParams(robust="huber")
    models = information_models(infos, loop, kernel)
    assert models[0] is models[3] and models[1] is models[4] and models[2] is not models[0]
    for model, info, robust in zip(models, infos, loop):  # each the model the per-factor call makes
        alone = information_model(info, kernel if robust else None)
        assert model.serialize() == alone.serialize()
    plain = information_models(infos, loop, None)  # no kernel: the loop closure shares A's plain model
    assert plain[0] is plain[2] is plain[3]


def test_poses_read_at_once_equal_those_read_one_by_one():
    from slamarena.estimators.gtsam_smoother.graph import L, poses_of

    rng = np.random.default_rng(0)
    ids = rng.permutation(50)
    values = gtsam.Values()
    for i in ids:
        values.insert(X(i), gtsam.Pose2(*rng.normal(size=3)))
    one_by_one = np.array([[p.x(), p.y(), p.theta()] for p in (values.atPose2(X(i)) for i in ids)])
    assert np.array_equal(poses_of(values, [X(i) for i in ids]), one_by_one)
    assert np.array_equal(poses_of(values, [X(i) for i in ids[:10]]), one_by_one[:10])  # a subset: one by one
    values.insert(L(3), gtsam.Point2(1.0, 2.0))
    assert np.array_equal(poses_of(values, [X(i) for i in ids]), one_by_one)  # landmarks beside the poses
    plain = gtsam.Values()  # keyed by the node ids (GTSAM's reader)
    for i in ids:
        plain.insert(int(i), values.atPose2(X(i)))
    assert np.array_equal(poses_of(plain, ids.tolist()), one_by_one)


def _bare_gtsam(path, anchor=0):
    """The bare GTSAM script of ``slamarena bench gtsam``: readG2o, a prior on the first node, Levenberg-Marquardt with
    tolerances 1e-8; its poses (in key order), final error and iterations."""
    graph, initial = gtsam.readG2o(str(path), False)
    graph.add(gtsam.PriorFactorPose2(anchor, initial.atPose2(anchor), gtsam.noiseModel.Isotropic.Sigma(3, 1e-6)))
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-8)
    params.setAbsoluteErrorTol(1e-8)
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, params)
    return gtsam.utilities.extractPose2(optimizer.optimize()), optimizer.error(), optimizer.iterations()


def _noisy_square_g2o(path, vertices: bool = True):
    """A g2o file of the noisy square loop (full, distinct information matrices; node ids from 10; the loop closures
    before the odometry) and its graph as read back."""
    truth = _square_loop()
    n = len(truth)
    rng = np.random.default_rng(7)
    i = np.arange(n - 1)
    loops = np.arange(0, n - 20, 4)
    ei, ej = np.concatenate([i, loops]), np.concatenate([i + 1, loops + 20])
    z = compose(between(truth[ei], truth[ej]), rng.normal(0, [0.05, 0.05, 0.02], (ei.size, 3)))
    A = rng.normal(size=(ei.size, 3, 3))
    info = A @ np.swapaxes(A, 1, 2) + np.diag([50.0, 50.0, 200.0])
    start = accumulate(np.zeros(3), z[: n - 1])
    graph = PoseGraph(
        name="square",
        node_ids=np.arange(n) + 10,
        edge_i=ei + 10,
        edge_j=ej + 10,
        edge_z=z,
        edge_information=info,
        poses=start,
    )
    g2o.write(path, graph)
    lines = path.read_text().splitlines()
    vertex = [line for line in lines if line.startswith("VERTEX")]
    edges = [line for line in lines if line.startswith("EDGE")]
    body = (vertex + edges[n - 1 :] + edges[: n - 1]) if vertices else edges
    path.write_text("\n".join(body) + "\n")
    return g2o.read(path)


def test_gtsams_reader_builds_the_same_problem_as_the_arrays(tmp_path):
    """On a validated, unedited g2o file the graph is GTSAM's readG2o's, keyed by the node ids: the same optimum bit for
    bit as the graph built from the arrays and as the bare GTSAM script."""
    graph = _noisy_square_g2o(tmp_path / "square.g2o")
    fast = PoseGraphOptimizer().run(graph)
    assert fast.meta["built_by"] == "gtsam.readG2o"
    edited = PoseGraph(**{**graph.__dict__, "meta": {}})  # the same arrays, no file behind them
    slow = PoseGraphOptimizer().run(edited)
    assert slow.meta["built_by"] == "arrays"
    assert np.array_equal(fast.poses, slow.poses)
    assert fast.diagnostics["final_error"] == slow.diagnostics["final_error"]
    assert fast.diagnostics["initial_error"] == slow.diagnostics["initial_error"]
    assert fast.diagnostics["iterations"] == slow.diagnostics["iterations"]
    bare, error, iterations = _bare_gtsam(tmp_path / "square.g2o", anchor=int(graph.node_ids[0]))
    assert np.array_equal(fast.poses, bare)
    assert fast.diagnostics["final_error"] == error
    assert fast.diagnostics["iterations"] == iterations
    covs = PoseGraphOptimizer(covariances=True)
    np.testing.assert_array_equal(covs.run(graph).pose_cov, covs.run(edited).pose_cov)


def test_gtsams_reader_is_used_only_for_the_files_unedited_content(tmp_path):
    """An edited array, a changed file, a robust kernel, chain initial values beside the file's vertices, landmark
    records, or a file GTSAM reads differently (a comment line stops readG2o) — each built from the arrays, so each
    solves the graph it is given."""
    import os

    path = tmp_path / "square.g2o"
    graph = _noisy_square_g2o(path)
    built = lambda g, **kw: PoseGraphOptimizer(**kw).run(g).meta["built_by"]  # noqa: E731
    assert built(graph) == "gtsam.readG2o"
    z = graph.edge_z.copy()
    z[-1, 0] += 1.0
    moved = PoseGraph(**{**graph.__dict__, "edge_z": z})  # a copy keeps the meta, not the content
    assert built(moved) == "arrays"
    est, ref = PoseGraphOptimizer().run(moved), PoseGraphOptimizer().run(PoseGraph(**{**moved.__dict__, "meta": {}}))
    assert np.array_equal(est.poses, ref.poses)
    graph.edge_information[0, 0, 0] *= 2.0  # edited in place
    assert built(graph) == "arrays"
    graph = g2o.read(path)
    assert built(graph, robust="huber") == "arrays" and built(graph, initial="chain") == "arrays"
    os.utime(path, ns=(0, 0))  # the file changed since it was read
    assert built(graph) == "arrays"
    commented = tmp_path / "commented.g2o"
    commented.write_text("# a comment\n" + path.read_text())
    assert built(g2o.read(commented)) == "arrays"
    chain = _noisy_square_g2o(tmp_path / "novertex.g2o", vertices=False)  # no vertices: GTSAM's chain, ours agree
    assert chain.poses is None and built(chain) == "gtsam.readG2o" and built(chain, initial="chain") == "gtsam.readG2o"
    landmarks = tmp_path / "landmarks.g2o"
    landmarks.write_text(path.read_text() + "VERTEX_XY 1000 1 2\nEDGE_SE2_XY 10 1000 1 2 10 0 10\n")
    assert built(g2o.read(landmarks)) == "arrays"


def test_a_gzipped_file_is_read_by_gtsam_through_a_temporary_copy(tmp_path):
    import gzip

    path = tmp_path / "square.g2o"
    graph = _noisy_square_g2o(path)
    packed = tmp_path / "square.g2o.gz"
    packed.write_bytes(gzip.compress(path.read_bytes()))
    est = PoseGraphOptimizer().run(g2o.read(packed))
    assert est.meta["built_by"] == "gtsam.readG2o"
    assert np.array_equal(est.poses, PoseGraphOptimizer().run(graph).poses)


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["intel", "manhattan", "city10000"])
def test_staged_pose_graph_optimum_is_the_bare_gtsam_scripts(name, tmp_path):
    """The wrapper (validated reader, GTSAM's reader on the validated file, checks) reaches the bare GTSAM script's
    optimum (what ``slamarena bench gtsam`` times it against) bit for bit: poses, final error, iterations."""
    import gzip
    import shutil

    from slamarena import datasets
    from slamarena.datasets.registry import resolve

    dataset = resolve(f"g2o:{name}")
    if not dataset.present():
        pytest.skip(f"g2o:{name} is not staged")
    est = PoseGraphOptimizer().run(datasets.load(f"g2o:{name}"))
    assert est.meta["built_by"] == "gtsam.readG2o"
    path = dataset.files()["graph"]
    if path.suffix == ".gz":
        with gzip.open(path, "rb") as src, open(tmp_path / path.stem, "wb") as dst:
            shutil.copyfileobj(src, dst)
        path = tmp_path / path.stem
    bare, error, iterations = _bare_gtsam(path)
    assert np.array_equal(est.poses, bare)
    assert est.diagnostics["final_error"] == error and est.diagnostics["iterations"] == iterations
