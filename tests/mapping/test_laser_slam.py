"""Laser graph SLAM: loop closure on a simulated loop, the robust back end against a false loop, the g2o and map
outputs, relations on a staged log."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from checks import load_staged, staged
from pydantic import ValidationError

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.formats import g2o
from slamarena.datasets.geometry import between, compose
from slamarena.datasets.sim.laser import simulate
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate
from slamarena.mapping.laser_slam import LaserSLAM
from slamarena.mapping.laser_slam.backend import Backend
from slamarena.mapping.laser_slam.refine import refine_scans
from slamarena.robust import RobustKernelParams

#: a hard loop: two laps, a short usable range and noisy odometry, so the submap front end drifts (0.16 m ATE without
#: loop closure, 0.04 m with)
HARD = dict(laps=2, k_r=0.1, k_rt=0.03, n_beams=181, seed=3)
FRONT = dict(
    frontend={"max_usable_range": 6.0}, loop={"search_every": 2}, tracking="submap"
)  # the front end drifts; the graph must close the loop


@pytest.fixture(scope="module")
def hard_loop():
    seq = simulate(**HARD)
    closed = LaserSLAM(**FRONT).run(seq)
    open_ = LaserSLAM(**{**FRONT, "loop": {**FRONT["loop"], "enabled": False}, "refine": {"neighbours": 0}}).run(seq)
    return seq, closed, open_


def test_closing_the_loop_reduces_the_error(hard_loop):
    seq, closed, open_ = hard_loop
    ref = reference_of(seq)
    e_closed = ate(closed, ref, ATEParams(align="se2"))[0]["rmse"]
    e_open = ate(open_, ref, ATEParams(align="se2"))[0]["rmse"]
    assert closed.meta["loop_closures"] > 0 and open_.meta["loop_candidates"] == 0
    assert e_closed < 0.4 * e_open, (e_closed, e_open)
    assert np.all(np.diff(closed.t) > 0) and len(closed.t) == len(seq.scans)  # one pose per scan stamp
    d = closed.diagnostics
    assert d["loop_accepted"].sum() == closed.meta["loop_closures"] and d["loop_seconds"].min() >= 0
    assert set(closed.meta["seconds"]) == {"front_end", "loop_search", "optimisation", "pairwise"}
    # the trajectory before loop closure is kept (the maps figure draws it beside the closed one): without loop
    # closure and refinement it is the trajectory itself
    assert closed.diagnostics["front_end_poses"].shape == closed.poses.shape
    np.testing.assert_allclose(open_.diagnostics["front_end_poses"], open_.poses, atol=1e-6)
    assert (
        ate(Estimate("laser_slam", closed.t, closed.diagnostics["front_end_poses"]), ref, ATEParams(align="se2"))[0][
            "rmse"
        ]
        > e_closed
    )


def test_step_times_are_measured_per_scan_and_sum_to_the_stage_totals(hard_loop):
    """Each scan's CPU time is measured (a loop search and the final solve charged to their scans), not the stage
    totals spread evenly: the times differ from scan to scan and enclose the stage timers, which run on the same
    clock (CPU time) inside them."""
    _, closed, _ = hard_loop
    steps, total = closed.step_time, sum(closed.meta["seconds"].values())
    assert steps.shape == closed.t.shape and steps.min() >= 0
    assert np.unique(steps).size > len(steps) // 2, "per-scan times are one constant"
    assert total <= steps.sum() <= 1.1 * total + 0.1, (steps.sum(), total)


def test_pairwise_refinement_cuts_the_short_range_error(hard_loop):
    """The local refinement (every scan registered onto its two predecessors, :mod:`slamarena.mapping.laser_slam.refine`)
    against the same run without it: the error of the motion between scans 1 and 3 apart drops (measured 0.0144 →
    0.0073 m and 0.0180 → 0.0111 m), the loops are the same, and the ATE does not grow (0.0362 → 0.0343 m: the nodes
    are held)."""
    seq, closed, _ = hard_loop
    plain = LaserSLAM(**FRONT, refine={"neighbours": 0}).run(seq)
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]

    def short(est, gap):
        return np.linalg.norm(
            between(est.poses[:-gap], est.poses[gap:])[:, :2] - between(truth[:-gap], truth[gap:])[:, :2], axis=1
        ).mean()

    for gap, factor in ((1, 0.6), (3, 0.75)):
        assert short(closed, gap) < factor * short(plain, gap), (gap, short(closed, gap), short(plain, gap))
    assert closed.meta["refinement"]["pairs"] > 1.9 * len(seq.scans) and plain.meta["refinement"] is None
    np.testing.assert_array_equal(closed.diagnostics["loop_accepted"], plain.diagnostics["loop_accepted"])
    ref = reference_of(seq)
    assert (
        ate(closed, ref, ATEParams(align="se2"))[0]["rmse"] < 1.05 * ate(plain, ref, ATEParams(align="se2"))[0]["rmse"]
    )


def test_refinement_holds_the_nodes_and_moves_the_scans_between_them():
    """Without pairwise factors the hanging scans are at their optimum (returned unchanged); a pairwise factor that
    disagrees moves the scans between two nodes and never the nodes."""
    rng = np.random.default_rng(1)
    K, node_scan = 30, np.arange(2, 30, 4)  # nodes every fourth scan from scan 2 on
    node_of = np.maximum(np.searchsorted(node_scan, np.arange(K), side="right") - 1, 0)
    G = np.column_stack(
        [np.arange(len(node_scan)) * 0.4, np.zeros(len(node_scan)), rng.uniform(-0.1, 0.1, len(node_scan))]
    )
    offsets = rng.uniform(-0.1, 0.1, (K, 3)) + [0.2, 0, 0]
    offsets[node_scan] = 0.0
    poses = compose(G[node_of], offsets)
    cov = np.diag([0.03**2, 0.03**2, 0.01**2])
    hanging = [
        (int(node_scan[node_of[k]]), k, offsets[k], cov) for k in range(node_scan[0] + 1, K) if k not in node_scan
    ]
    kernel = RobustKernelParams(robust="cauchy", robust_k=1.0)
    out, report = refine_scans(poses, node_scan, hanging, [], kernel)
    np.testing.assert_allclose(out, poses, atol=1e-9)
    assert report["variables"] == K - 2 and report["pairs"] == 0
    pair = (8, 9, between(poses[8], poses[9]) + [0.05, 0.0, 0.0], np.diag([1e-4, 1e-4, 1e-5]))  # scan 10 is a node
    moved, _ = refine_scans(poses, node_scan, hanging, [pair], RobustKernelParams(robust="none"))
    np.testing.assert_allclose(moved[node_scan], poses[node_scan], atol=1e-5)
    assert np.hypot(*(moved[9, :2] - poses[9, :2])) > 0.01 and np.hypot(*(moved[8, :2] - poses[8, :2])) > 0.005
    np.testing.assert_allclose(moved[:7], poses[:7], atol=1e-6)  # the other runs of scans do not move


def _chain(n=60, seed=0):
    """A square loop of n poses, its odometry with noise, and the true loop constraints."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    truth = np.column_stack([5 * np.cos(s), 5 * np.sin(s), s + np.pi / 2])
    z = between(truth[:-1], truth[1:]) + rng.standard_normal((n - 1, 3)) * [0.02, 0.02, 0.01]
    return truth, z


def _optimise(truth, z, loops, kernel):
    backend = Backend(kernel)
    cov = np.diag([0.02**2, 0.02**2, 0.01**2])
    G = [truth[0]]
    backend.add_node(0, truth[0])
    for i, zi in enumerate(z, start=1):
        G.append(compose(G[-1], zi))
        backend.add_node(i, G[-1], zi, cov)
    for a, n, zz in loops:
        backend.add_loop(a, n, zz, np.diag([0.05**2, 0.05**2, 0.01**2]))
    return backend.finish()[0]


def test_a_false_loop_is_down_weighted_by_the_robust_kernel():
    truth, z = _chain()
    true_loops = [(0, 59, between(truth[0], truth[59])), (5, 55, between(truth[5], truth[55]))]
    false_loop = [(10, 40, np.array([0.5, 0.0, 0.0]))]  # nodes 10 and 40 are 10 m apart

    def error(poses):
        return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))

    clean = error(_optimise(truth, z, true_loops, RobustKernelParams(robust="cauchy", robust_k=1.0)))
    robust = error(_optimise(truth, z, true_loops + false_loop, RobustKernelParams(robust="cauchy", robust_k=1.0)))
    plain = error(_optimise(truth, z, true_loops + false_loop, RobustKernelParams(robust="none")))
    assert robust < 1.5 * clean + 0.02, (robust, clean)
    assert plain > 10 * robust, (plain, robust)


def test_injected_false_loops_do_not_bend_the_map(hard_loop):
    """Two false loops (each claims a node sits 5 m from where it is, as tight as the tightest real loop) on the
    simulated loop: the Cauchy kernel leaves the ATE where it was and the final poses ignore the false claims."""
    seq, closed, _ = hard_loop
    est = LaserSLAM(**{**FRONT, "loop": {**FRONT["loop"], "false_loops": 2}}).run(seq)
    ref = reference_of(seq)
    e_closed = ate(closed, ref, ATEParams(align="se2"))[0]["rmse"]
    e_false = ate(est, ref, ATEParams(align="se2"))[0]["rmse"]
    d = est.diagnostics
    assert est.meta["false_loops"] == d["false_loop_node"].size == 2
    G = est.poses[d["node_scan"]]  # the nodes' optimised poses
    apart = np.hypot(*(G[d["false_loop_node"], :2] - G[d["false_loop_anchor"], :2]).T)
    assert np.all(apart > 4.0), apart  # the claim "these two nodes coincide" was not obeyed
    assert e_false < 1.1 * e_closed + 0.005, (e_false, e_closed)


#: the aliasing drive (research/notebook/2026-11-28-loop-verification.md): two laps of the corridor ring with the
#: loop_closure config's noisy odometry and an 8 m laser that sees into the rooms; seed 3 was not used to choose any
#: parameter (seeds 0 and 1 were)
ALIAS_DRIVE = dict(max_range=8.0, n_beams=91, sigma_range=0.02, k_r=0.06, k_rt=0.03, k_t=0.085, scan_rate=2.5, laps=2)


def _false_loops(seq, est) -> int:
    """Accepted loops whose constraint is more than 1 m or 0.1 rad from the true relative pose of its two nodes."""
    d = est.diagnostics
    truth = seq.ground_truth.poses[np.searchsorted(seq.ground_truth.t, seq.scans.t)][d["node_scan"]]
    ok = d["loop_accepted"]
    err = d["loop_z"][ok] - between(truth[d["loop_anchor"][ok]], truth[d["loop_node"][ok]])
    return int(np.sum((np.hypot(err[:, 0], err[:, 1]) > 1.0) | (np.abs(np.angle(np.exp(1j * err[:, 2]))) > 0.1)))


def test_no_false_loop_survives_perceptual_aliasing():
    """``aliased_rooms``: identical rooms every 4 m along the corridor ring, so a scan matches 4 m along as well as at
    its own place (the code before the verification accepted 162 false loops of 252 here, ATE 1.11 m). With the
    uniqueness test and GNC (shipped defaults: the windows at their 5 m floor) no accepted loop is false (measured: 48
    accepted, 194 ambiguous), and the ATE is that of the same drive past rooms that all differ (``distinct_rooms``,
    where the front end sees the same walls; measured 0.273 against 0.210 m)."""
    runs = {}
    for world in ("aliased_rooms", "distinct_rooms"):
        seq = simulate(world=world, seed=3, **ALIAS_DRIVE)
        est = LaserSLAM().run(seq)
        runs[world] = (_false_loops(seq, est), ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"], est)
    (false, e_aliased, est), (_, e_distinct, _) = runs["aliased_rooms"], runs["distinct_rooms"]
    m = est.meta
    assert false == 0 and m["loop_closures"] >= 20, (false, m["loop_closures"])
    assert m["loop_rejected_by"]["ambiguous"] > 0  # the repeats were seen and refused
    assert m["loop_closures"] + sum(m["loop_rejected_by"].values()) == m["loop_candidates"]
    assert e_aliased < 1.5 * e_distinct, (e_aliased, e_distinct)


def test_pose_graph_written_as_g2o_reads_back(hard_loop, tmp_path):
    seq, _, _ = hard_loop
    slam = LaserSLAM(**FRONT)
    est = slam.run(dataclasses.replace(seq, scans=_first(seq.scans, 300)))
    graph = slam.pose_graph
    g2o.write(tmp_path / "graph.g2o", graph)
    back = g2o.read(tmp_path / "graph.g2o")
    np.testing.assert_array_equal(back.edge_i, graph.edge_i)
    np.testing.assert_allclose(back.edge_z, graph.edge_z, rtol=1e-15)
    np.testing.assert_allclose(back.edge_information, graph.edge_information, rtol=1e-12)
    np.testing.assert_allclose(back.poses, graph.poses, rtol=1e-15, atol=1e-15)
    assert graph.n_nodes == est.meta["nodes"] and graph.meta["loop_edges"] == est.meta["loop_closures"]
    assert slam.map is not None and slam.map.shape[0] > 10


def _first(scans, n):
    return dataclasses.replace(
        scans, t=scans.t[:n], ranges=scans.ranges[:n], pose=None if scans.pose is None else scans.pose[:n]
    )


def test_parameters_are_typed():
    with pytest.raises(ValidationError, match="submap_scans"):
        LaserSLAM(submap_scans=0)
    with pytest.raises(ValidationError, match="robust_kernel.robust"):
        LaserSLAM(robust_kernel={"robust": "tukey"})
    with pytest.raises(ValidationError, match="loop_sigma: not a parameter of LaserSLAMParams; did you mean"):
        LaserSLAM(loop_sigma=0.1)
    with pytest.raises(
        ValidationError, match=r"loop_level: not a parameter of LaserSLAMParams; did you mean loop\.level\?"
    ):
        LaserSLAM(loop_level=2)
    with pytest.raises(ValidationError, match=r"refine_neighbours: .*; did you mean refine\.neighbours\?"):
        LaserSLAM(refine_neighbours=0)
    with pytest.raises(
        ValidationError, match=r"loop\.levl\s+levl: not a parameter of LoopClosureParams; did you mean level\?"
    ):
        LaserSLAM(loop={"levl": 2})
    assert LaserSLAM(LaserSLAM.Params(submap_scans=20)).params == LaserSLAM(submap_scans=20).params
    # a section laid over the method's defaults: the kernel keeps laser SLAM's width 1 when only its type is given
    assert LaserSLAM(robust_kernel={"robust": "huber"}).params.robust_kernel.robust_k == 1.0
    base = LaserSLAM.Params(loop={"level": 2})
    assert LaserSLAM(base, loop={"voxel": 0.2}).params.loop.model_dump(include={"level", "voxel"}) == {
        "level": 2,
        "voxel": 0.2,
    }


@pytest.mark.realdata
def test_relations_on_mit_csail():
    """The front end alone and with loop closure on the staged MIT-CSAIL log, scored by its relations."""
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file

    relations = staged("radish_laser_logs/relations/mit-csail.relations")
    seq = load_staged("carmen:mit-csail")
    est = LaserSLAM().run(seq)
    scores, _ = relation_error_from_file(est, seq, RelationsParams(file=relations))
    assert scores["used"] == 1172
    # measured 0.0313 ± 0.0364 with the pairwise refinement, 0.0322 ± 0.0364 without (research/notebook/2026-11-23-kummerle2009.md): far
    # below the published scan matching (0.106 ± 0.325), below Cartographer's 0.0319 ± 0.0363 (the goal), and above
    # graph mapping's 0.004 ± 0.009
    assert scores["trans_mean"] < 0.0319 and scores["trans_std"] < 0.04
    assert est.meta["refinement"]["pairs"] > 3900
    assert est.meta["loop_closures"] > 50


@pytest.mark.realdata
def test_mit_csail_short_relations_are_the_flaser_increments_moved_by_whole_5cm_cells():
    """Why MIT-CSAIL's relation error stops near 2.5 cm (research/notebook/2026-11-23-kummerle2009.md): each short relation's translation is
    the log's FLASER pose increment plus a whole number of 5 cm cells (|difference| = 5 cm · √(a² + b²): 0, 5, 7.07,
    10 … cm), never anything between — the reference positions are quantised to a 5 cm lattice, and a pose that is
    right to the millimetre is still half a cell off the reference on average."""
    from slamarena.datasets.formats import relations

    seq = load_staged("carmen:mit-csail")
    rel = relations.read(staged("radish_laser_logs/relations/mit-csail.relations"))
    ipc, odom = np.asarray(seq.meta["scan_ipc_timestamp"]), seq.scans.pose
    i, j = (np.abs(ipc[None] - t[:, None]).argmin(1) for t in (rel.t1, rel.t2))
    fresh = np.array(
        [b - a <= 3 and all(np.any(odom[k] != odom[k - 1]) for k in range(a + 1, b + 1)) for a, b in zip(i, j)]
    )
    cells = np.linalg.norm(rel.se2[fresh, :2] - between(odom[i[fresh]], odom[j[fresh]])[:, :2], axis=1) / 0.05
    assert fresh.sum() > 1000
    np.testing.assert_allclose(cells, np.sqrt(np.round(cells**2)), atol=0.02)  # on the lattice, to 1 mm
    assert (
        0.4 < np.mean(cells < 0.02) < 0.6 and np.mean((cells > 0.98) & (cells < 1.02)) > 0.25
    )  # half equal, a third one cell off


def test_relative_pose_covariances_are_given_in_the_frame_gtsam_measures_the_error_in():
    """A relative pose z whose covariance Σ is known in its start's frame: GTSAM's BetweenFactorPose2 error,
    Log(z⁻¹ z'), of perturbed z' = (t + Δt, θ + Δθ), (Δt, Δθ) ~ N(0, Σ), has the covariance ``_in_end_frame`` gives
    (the rotation of the start frame by z's heading), not Σ itself — checked by sampling for an anisotropic Σ."""
    import gtsam

    from slamarena.mapping.laser_slam.slam import _in_end_frame

    rng = np.random.default_rng(2)
    z = np.array([1.0, 0.5, 1.1])
    Sigma = np.diag([0.05, 0.002, 0.001]) ** 2
    d = rng.multivariate_normal(np.zeros(3), Sigma, 20000)
    zp = gtsam.Pose2(*z)
    err = np.array([zp.localCoordinates(gtsam.Pose2(z[0] + a, z[1] + b, z[2] + c)) for a, b, c in d])
    expected = _in_end_frame(Sigma, z[2])
    np.testing.assert_allclose(np.cov(err.T), expected, atol=0.03 * Sigma[0, 0])
    assert np.abs(np.cov(err.T) - Sigma).max() > 10 * 0.03 * Sigma[0, 0]  # the unrotated Σ is far off
