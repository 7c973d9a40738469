"""Metrics: ATE/RPE against evo on the same trajectories, and known-answer cases for every metric."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import LandmarkMap, RangeBearing, Sequence, Trajectory
from slamarena.experiments.metrics import METRICS, CellData, MetricUnavailable, evaluate, reference_of
from slamarena.experiments.metrics.alignment import Alignment, umeyama
from slamarena.experiments.metrics.consistency import NEESParams, chi2_band, monte_carlo, nees, nis
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.relations import RelationsParams, relation_error
from slamarena.experiments.metrics.trajectory import ATEParams, RPEParams, ate, rpe, rpe_pairs


def _truth(K=300, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(K) * 0.1
    delta = np.column_stack(
        [0.1 + 0.05 * rng.random(K - 1), 0.01 * rng.standard_normal(K - 1), 0.05 + 0.03 * rng.standard_normal(K - 1)]
    )
    from slamarena.datasets.geometry import accumulate

    return t, accumulate([0.0, 0.0, 0.2], delta)


def _noisy(poses, sigma=(0.05, 0.05, 0.02), seed=1):
    rng = np.random.default_rng(seed)
    out = poses + rng.standard_normal(poses.shape) * sigma
    out[:, 2] = wrap_angle(out[:, 2])
    return out


def _ref(t, poses, landmarks=None):
    lm = None if landmarks is None else LandmarkMap(ids=landmarks[0], xy=landmarks[1])
    return reference_of(Sequence("truth", ground_truth=Trajectory(t=t, poses=poses), landmarks=lm))


# ----------------------------------------------------------------------------- evo cross-checks
def _evo(t, poses):
    from evo.core.trajectory import PoseTrajectory3D

    xyz = np.column_stack([poses[:, :2], np.zeros(len(poses))])
    half = poses[:, 2] / 2
    quat = np.column_stack([np.cos(half), np.zeros(len(poses)), np.zeros(len(poses)), np.sin(half)])
    return PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=quat, timestamps=np.asarray(t, float))


@pytest.mark.parametrize("align", ["none", "se2", "sim2"])
def test_ate_matches_evo(align):
    from evo.core import metrics, sync

    t, gt = _truth()
    est = Alignment(0.7, (3.0, -2.0), 1.3 if align == "sim2" else 1.0).poses(_noisy(gt))
    # the estimate has every other stamp only; evo associates by nearest time
    est_t, est = t[::2], est[::2]
    ours, _ = ate(Estimate("x", est_t, est), _ref(t, gt), ATEParams(align=align))
    ref_e, est_e = sync.associate_trajectories(_evo(t, gt), _evo(est_t, est), max_diff=1e-6)
    if align != "none":
        est_e.align(ref_e, correct_scale=align == "sim2")
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref_e, est_e))
    stats = ape.get_all_statistics()
    for key in ("rmse", "mean", "median", "max"):
        assert ours[key] == pytest.approx(stats[key], abs=1e-6)
    rot = metrics.APE(metrics.PoseRelation.rotation_angle_rad)
    rot.process_data((ref_e, est_e))
    assert ours["heading_rmse"] == pytest.approx(rot.get_all_statistics()["rmse"], abs=1e-6)
    assert ours["heading_max"] == pytest.approx(rot.get_all_statistics()["max"], abs=1e-6)


@pytest.mark.parametrize(
    "unit,delta,all_pairs",
    [("frames", 1, True), ("frames", 7, False), ("frames", 5, True), ("m", 2.0, True), ("m", 1.5, False)],
)
def test_rpe_matches_evo(unit, delta, all_pairs):
    from evo.core import metrics

    t, gt = _truth()
    est = _noisy(gt)
    params = RPEParams(delta=delta, unit=unit, all_pairs=all_pairs)
    ours, _ = rpe(Estimate("x", t, est), _ref(t, gt), params)
    evo_unit = metrics.Unit.frames if unit == "frames" else metrics.Unit.meters
    for relation, keys in (
        (metrics.PoseRelation.translation_part, ("trans_rmse", "trans_mean", "trans_median", "trans_max")),
        (metrics.PoseRelation.rotation_angle_rad, ("rot_rmse", "rot_mean", None, "rot_max")),
    ):
        m = metrics.RPE(relation, delta=delta, delta_unit=evo_unit, all_pairs=all_pairs, pairs_from_reference=True)
        m.process_data((_evo(t, gt), _evo(t, est)))
        stats = m.get_all_statistics()
        assert ours["pairs"] == len(m.error)
        for key, evo_key in zip(keys, ("rmse", "mean", "median", "max")):
            if key:
                assert ours[key] == pytest.approx(stats[evo_key], abs=1e-6)


# ----------------------------------------------------------------------------- known answers
def test_umeyama_recovers_a_similarity_and_rejects_reflections():
    rng = np.random.default_rng(2)
    p = rng.normal(size=(40, 2))
    A = Alignment(-2.1, (5.0, 1.0), 0.4)
    B = umeyama(p, A.points(p), with_scale=True)
    assert B.angle == pytest.approx(-2.1) and B.scale == pytest.approx(0.4)
    np.testing.assert_allclose(B.translation, (5.0, 1.0))
    mirrored = p * [1, -1]
    C = umeyama(p, mirrored, with_scale=False)  # best proper rotation, never a reflection
    assert np.isfinite(C.angle) and C.scale == 1.0


def test_rotated_shifted_copy_aligns_to_zero_error():
    t, gt = _truth()
    moved = Alignment(1.1, (-4.0, 7.0)).poses(gt)
    res, _ = ate(Estimate("x", t, moved), _ref(t, gt), ATEParams(align="se2"))
    assert res["rmse"] < 1e-9 and res["heading_max"] < 1e-9
    scaled = Alignment(1.1, (-4.0, 7.0), 2.5).poses(gt)
    assert ate(Estimate("x", t, scaled), _ref(t, gt), ATEParams(align="sim2"))[0]["rmse"] < 1e-9
    assert ate(Estimate("x", t, scaled), _ref(t, gt), ATEParams(align="se2"))[0]["rmse"] > 1.0


def test_constant_offset_gives_that_offset():
    t, gt = _truth()
    shifted = gt + [0.3, -0.4, 0.05]
    res, series = ate(Estimate("x", t, shifted), _ref(t, gt), ATEParams(align="none"))
    for key in ("rmse", "mean", "median", "max"):
        assert res[key] == pytest.approx(0.5)
    assert res["heading_rmse"] == pytest.approx(0.05) and res["heading_max"] == pytest.approx(0.05)
    # a world-frame offset leaves relative poses changed only by the heading offset; a pure
    # translation leaves RPE at zero
    res = rpe(Estimate("x", t, gt + [0.3, -0.4, 0.0]), _ref(t, gt), RPEParams(delta=1.0, unit="s"))[0]
    assert res["trans_max"] < 1e-12 and res["rot_max"] < 1e-12


def test_ground_truth_interpolated_and_time_gap_enforced():
    # ground truth along the x axis at 1 m/s, sampled at 1 Hz with a 5 s hole
    gt_t = np.r_[np.arange(0.0, 10.0), np.arange(15.0, 20.0)]
    gt = np.column_stack([gt_t, np.zeros_like(gt_t), np.zeros_like(gt_t)])
    est_t = np.arange(0.0, 19.0, 0.25)
    est = np.column_stack([est_t, np.zeros_like(est_t), np.zeros_like(est_t)])
    res, series = ate(Estimate("x", est_t, est), _ref(gt_t, gt), ATEParams(align="none", max_gap=1.0))
    assert res["max"] < 1e-12  # interpolation is exact on a straight line
    inside_hole = (est_t > 9.0) & (est_t < 15.0)
    assert res["unmatched"] == int(inside_hole.sum())
    res = ate(Estimate("x", est_t, est), _ref(gt_t, gt), ATEParams(align="none", max_gap=0.1))[0]
    assert res["matched"] == int(np.isin(est_t, gt_t).sum())  # only exact stamps remain


def test_rpe_known_answer_drift():
    # a heading bias of b rad per frame gives a rotational RPE of exactly b·Δ for Δ frames
    t, gt = _truth()
    b = 0.002
    from slamarena.datasets.geometry import accumulate, between

    d = between(gt[:-1], gt[1:]) + [0, 0, b]
    est = accumulate(gt[0], d)
    res, _ = rpe(Estimate("x", t, est), _ref(t, gt), RPEParams(delta=10, unit="frames"))
    assert res["rot_mean"] == pytest.approx(10 * b) and res["rot_max"] == pytest.approx(10 * b)
    # seconds: pairs 1 s apart at 10 Hz are 10 frames apart
    np.testing.assert_array_equal(
        rpe_pairs(t, gt[:, :2], 1.0, "s", rel_tol=0.01), rpe_pairs(t, gt[:, :2], 10, "frames")
    )


def test_nees_consistent_and_inconsistent():
    rng = np.random.default_rng(4)
    t, gt = _truth(K=2000)
    L = np.array([[0.2, 0, 0], [0.05, 0.1, 0], [0.01, 0.02, 0.05]])
    P = L @ L.T
    est = gt + rng.standard_normal(gt.shape) @ L.T
    est[:, 2] = wrap_angle(est[:, 2])
    e = Estimate("x", t, est, pose_cov=np.broadcast_to(P, (len(t), 3, 3)))
    res, series = nees(e, _ref(t, gt))
    assert res["mean"] == pytest.approx(3.0, rel=0.1)
    assert res["in_band"] == pytest.approx(0.95, abs=0.02)
    over = Estimate("x", t, est, pose_cov=np.broadcast_to(P / 4, (len(t), 3, 3)))  # overconfident
    assert nees(over, _ref(t, gt))[0]["mean"] == pytest.approx(12.0, rel=0.1)
    # body frame: errors drawn in the tangent space at the estimate
    from slamarena.datasets.geometry import se2_exp

    xi = rng.standard_normal(gt.shape) @ L.T
    est_body = compose(gt, se2_exp(-xi))  # gt = est ⊕ Exp(ξ') with ξ' ≈ ξ for small ξ
    eb = Estimate("x", t, est_body, pose_cov=np.broadcast_to(P, (len(t), 3, 3)))
    assert nees(eb, _ref(t, gt), NEESParams(frame="body"))[0]["mean"] == pytest.approx(3.0, rel=0.1)
    with pytest.raises(MetricUnavailable):
        nees(Estimate("x", t, est), _ref(t, gt))


def test_chi2_bands_and_monte_carlo_average():
    from scipy.stats import chi2

    lo, hi = chi2_band(3)
    assert lo == pytest.approx(0.2158, abs=1e-3) and hi == pytest.approx(9.348, abs=1e-3)
    for dof, runs in ((1, 1), (2, 7), (3, 50), (4, 200)):
        np.testing.assert_allclose(chi2_band(dof, runs, 0.99), chi2.ppf([0.005, 0.995], runs * dof) / runs, rtol=1e-10)
    rng = np.random.default_rng(9)
    lo, hi = chi2_band(3, runs=50)  # N ε̄ ~ χ²(150): the empirical quantiles of averages of 50 χ²(3)
    averages = rng.chisquare(3, (100_000, 50)).mean(axis=1)
    np.testing.assert_allclose(np.quantile(averages, [0.025, 0.975]), [lo, hi], rtol=1e-2)
    t = np.arange(500) * 0.1
    runs = [(t, rng.chisquare(3, t.size)) for _ in range(50)]
    mc = monte_carlo(runs, 3)
    assert mc["runs"] == 50 and mc["in_band"] > 0.9
    biased = [(t, 1.5 * v) for t, v in runs]
    assert monte_carlo(biased, 3)["in_band"] < 0.1
    # runs with different stamps are averaged at the shared ones
    short = [(t[:100], v[:100]) for t, v in runs[:10]] + runs[10:]
    assert monte_carlo(short, 3)["t"].size == 100


def test_nis_from_diagnostics():
    rng = np.random.default_rng(5)
    dof = rng.choice([2, 4], 3000)
    value = rng.chisquare(dof)
    value[7] = np.nan
    e = Estimate("x", [0.0], [[0, 0, 0]], diagnostics={"nis": value, "nis_dof": dof})
    res, _ = nis(e)
    assert res["mean_over_dof"] == pytest.approx(1.0, rel=0.05) and res["in_band"] == pytest.approx(0.95, abs=0.015)
    assert res["count"] == 2999


def test_landmark_error_by_id_and_nearest():
    rng = np.random.default_rng(6)
    t, gt = _truth()
    ids = np.arange(30)
    xy = rng.uniform(-10, 10, (30, 2))
    A = Alignment(0.5, (2.0, -1.0))
    ref = _ref(t, gt, (ids, xy))
    est_poses = A.poses(gt)
    # the estimate lives in a rotated, shifted frame; 25 landmarks with a 0.1 m error along x,
    # plus 3 spurious ones, 5 missed
    est_lm = A.points(xy[:25] + [0.1, 0.0])
    spurious = A.points(np.array([[50.0, 50.0], [60.0, 50.0], [50.0, 70.0]]))
    e = Estimate(
        "x", t, est_poses, landmark_ids=np.r_[ids[:25], 100, 101, 102], landmarks=np.vstack([est_lm, spurious])
    )
    res, _ = landmark_error(e, ref, MapParams(by="id"))
    assert res["rmse"] == pytest.approx(0.1) and res["matched"] == 25 and res["missed"] == 5 and res["spurious"] == 3
    unknown = Estimate(
        "x", t, est_poses, landmark_ids=np.full(28, -1), landmarks=rng.permutation(np.vstack([est_lm, spurious]))
    )
    res, _ = landmark_error(unknown, ref, MapParams(by="nearest", max_distance=1.0))
    assert res["rmse"] == pytest.approx(0.1) and res["matched"] == 25 and res["missed"] == 5 and res["spurious"] == 3


def test_missed_counts_only_observed_landmarks():
    t, gt = _truth(K=20)
    xy = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    rb = RangeBearing(t=[0.5, 0.5], range=[1, 1], bearing=[0, 0], landmark_id=[0, 1])
    seq = Sequence(
        "s", range_bearing=rb, ground_truth=Trajectory(t=t, poses=gt), landmarks=LandmarkMap(ids=[0, 1, 2], xy=xy)
    )
    e = Estimate("x", t, gt, landmark_ids=[0], landmarks=xy[:1])
    res, _ = landmark_error(e, reference_of(seq), MapParams(align="none"))
    assert res["missed"] == 1 and res["rmse"] == 0.0  # landmark 2 was never observed


def test_relation_error_known_answer():
    t, gt = _truth()
    from slamarena.datasets.geometry import between

    i, j = np.arange(0, 280, 10), np.arange(20, 300, 10)
    reference = between(gt[i], gt[j])
    exact, _ = relation_error(Estimate("x", t, gt), t[i], t[j], reference)
    assert exact["trans_mean"] < 1e-12 and exact["rot_mean"] < 1e-12 and exact["used"] == len(i)
    # every reference relation off by 0.1 m along its own x and 0.02 rad: the error is that
    off = compose(reference, np.array([0.1, 0.0, 0.02]))
    res, _ = relation_error(Estimate("x", t, gt), t[i], t[j], off)
    assert (
        res["trans_mean"] == pytest.approx(0.1) and res["rot_mean"] == pytest.approx(0.02) and res["trans_std"] < 1e-9
    )
    # stamps 0.03 s off: nearest within 0.05 s still matches; tolerance 0.01 s drops them all
    assert relation_error(Estimate("x", t, gt), t[i] + 0.03, t[j] + 0.03, reference)[0]["used"] == len(i)
    with pytest.raises(MetricUnavailable):
        relation_error(Estimate("x", t, gt), t[i] + 0.03, t[j] + 0.03, reference, RelationsParams(tolerance=0.01))
    from slamarena.datasets.geometry import interpolate_poses

    mid_i, mid_j = interpolate_poses(t, gt, t[i] + 0.05), interpolate_poses(t, gt, t[j] + 0.05)
    interp, _ = relation_error(
        Estimate("x", t, gt), t[i] + 0.05, t[j] + 0.05, between(mid_i, mid_j), RelationsParams(match="interpolate")
    )
    assert interp["used"] == len(i) and interp["trans_mean"] < 1e-12
    # …whereas the nearest pose is a whole step away from the mid-point: a visible error
    assert (
        relation_error(
            Estimate("x", t, gt), t[i] + 0.05, t[j] + 0.05, between(mid_i, mid_j), RelationsParams(tolerance=0.06)
        )[0]["trans_mean"]
        > 1e-3
    )
    # local relations (stamps closer than local_span) are scored apart from the others
    a, b = (
        np.arange(0, 100, 10),
        np.arange(0, 100, 10) + np.where(np.arange(10) < 6, 5, 150),
    )  # 6 short spans, 4 long ones
    short = (t[b] - t[a]) < (t[155] - t[0]) / 2
    ref = np.where(short[:, None], between(gt[a], gt[b]), compose(between(gt[a], gt[b]), np.array([0.1, 0.0, 0.0])))
    split = relation_error(
        Estimate("x", t, gt), t[a], t[b], ref, RelationsParams(local_span=float((t[155] - t[0]) / 2))
    )[0]
    assert (
        split["local"] == 6 and split["local_trans_mean"] < 1e-12 and split["global_trans_mean"] == pytest.approx(0.1)
    )


def test_revisit_relations_score_a_loops_overlap():
    """Two laps of a circle of radius 10 m, 100 poses a lap: every 5th pose of lap 1 is paired with the same place on
    lap 2 (pose i + 100, 62.8 m of path on). An estimate equal to the truth
    scores 0; one whose second lap is displaced by 0.3 m scores 0.3 m on every pair: a drift that does not close."""
    from slamarena.experiments.metrics.relations import revisit_relations

    a = np.linspace(0.0, 4 * np.pi, 200, endpoint=False)
    truth = np.column_stack([10 * np.sin(a), 10 - 10 * np.cos(a), a])
    t = np.arange(200) * 0.5
    t_i, t_j, delta = revisit_relations(t, truth, radius=0.25, min_travel=20.0, stride=5)
    np.testing.assert_array_equal(t_i, t[0:100:5])
    np.testing.assert_array_equal(t_j, t[100:200:5])
    np.testing.assert_allclose(delta, 0.0, atol=1e-9)  # the same pose one lap later
    assert relation_error(Estimate("x", t, truth), t_i, t_j, delta)[0]["trans_mean"] < 1e-9
    shifted = truth.copy()
    shifted[100:, 0] += 0.3
    res = relation_error(Estimate("x", t, shifted), t_i, t_j, delta)[0]
    assert res["trans_mean"] == pytest.approx(0.3) and res["rot_mean"] < 1e-9 and res["used"] == 20
    assert revisit_relations(t, truth, radius=0.25, min_travel=100.0)[0].size == 0  # no revisit is 100 m of path on


def test_loop_metric_scores_the_revisits_of_the_ground_truth():
    """The ``loop`` metric on the two-lap circle: 0 for the truth, the second lap's 0.3 m displacement for an estimate
    that does not close, and unavailable (with the reason) on a path that never revisits a place."""
    a = np.linspace(0.0, 4 * np.pi, 200, endpoint=False)
    truth = np.column_stack([10 * np.sin(a), 10 - 10 * np.cos(a), a])
    t = np.arange(200) * 0.5
    seq = Sequence("circle", ground_truth=Trajectory(t=t, poses=truth))
    shifted = truth.copy()
    shifted[100:, 0] += 0.3
    loop = lambda poses: evaluate(
        CellData(Estimate("x", t, poses), seq, reference_of(seq)), {"loop": METRICS["loop"].params()}
    )
    assert loop(truth)[0]["loop"]["trans_mean"] < 1e-9
    scores = loop(shifted)[0]["loop"]
    assert scores["trans_mean"] == pytest.approx(0.3) and scores["used"] == 20
    one_lap = Sequence("arc", ground_truth=Trajectory(t=t[:100], poses=truth[:100]))
    skipped = evaluate(
        CellData(Estimate("x", t[:100], truth[:100]), one_lap, reference_of(one_lap)),
        {"loop": METRICS["loop"].params()},
    )[2]
    assert "revisits no place" in skipped["loop"]


def test_cost_and_evaluate_records_skipped_metrics():
    t, gt = _truth(K=50)
    e = Estimate("x", t, gt, step_time=np.r_[np.full(49, 0.001), 0.1])
    seq = Sequence("s", ground_truth=Trajectory(t=t, poses=gt))
    selected = {k: METRICS[k].params() for k in ("ate", "nees", "cost", "map")}
    scalars, series, skipped = evaluate(CellData(e, seq, reference_of(seq), wall=0.5, peak_rss=123.0), selected)
    assert scalars["cost"]["step_median"] == pytest.approx(0.001)
    assert scalars["cost"]["step_total"] == pytest.approx(0.149)
    assert scalars["cost"]["peak_rss_mb"] == 123.0
    assert "realtime" not in scalars["cost"]  # a sequence without input streams has no duration
    recording = Sequence(
        "s",
        ground_truth=Trajectory(t=t, poses=gt),
        range_bearing=RangeBearing(t=[1.0, 11.0], range=[1, 1], bearing=[0, 0], landmark_id=[0, 1]),
    )
    timed = evaluate(CellData(e, recording, reference_of(recording), wall=0.5), {"cost": METRICS["cost"].params()})[0]
    assert timed["cost"]["realtime"] == pytest.approx(10.0 / 0.5)  # the recording's span over the wall time
    assert scalars["ate"]["rmse"] < 1e-12
    assert set(skipped) == {"nees", "map"} and "covariance" in skipped["nees"]


def test_relations_file_through_the_reader(tmp_path):
    from slamarena.datasets.formats import relations as fmt
    from slamarena.datasets.geometry import between
    from slamarena.experiments.metrics.relations import relation_error_from_file

    t, gt = _truth()
    i, j = np.arange(0, 250, 25), np.arange(25, 275, 25)
    d = compose(between(gt[i], gt[j]), np.array([0.0, 0.2, 0.0]))
    motion = np.column_stack([d[:, 0], d[:, 1], np.zeros(len(i)), np.zeros(len(i)), np.zeros(len(i)), d[:, 2]])
    path = tmp_path / "toy.relations"
    fmt.write(path, fmt.Relations(t1=t[i], t2=t[j], motion=motion))
    res, _ = relation_error_from_file(Estimate("x", t, gt), Sequence("s"), RelationsParams(file=path))
    assert res["trans_mean"] == pytest.approx(0.2) and res["used"] == len(i)
    with pytest.raises(MetricUnavailable, match="no relations file"):
        relation_error_from_file(Estimate("x", t, gt), Sequence("s"), RelationsParams())


def test_nis_monte_carlo_sums_innovations_per_stamp():
    from slamarena.experiments.metrics.consistency import nis_per_stamp

    rng = np.random.default_rng(13)
    per_stamp = rng.integers(1, 4, 200)  # 1–3 range-bearing innovations (dof 2) per stamp, same in every run
    t = np.repeat(np.arange(200) * 0.1, per_stamp)
    dof = np.full(t.size, 2.0)
    runs = [nis_per_stamp(t, rng.chisquare(2, t.size), dof) for _ in range(20)]
    ts, sums, dims = runs[0]
    np.testing.assert_array_equal(dims, 2 * per_stamp)
    mc = monte_carlo(runs)
    assert mc["t"].size == 200 and mc["in_band"] > 0.9
    assert np.mean(mc["mean"] / mc["dof"]) == pytest.approx(1.0, abs=0.03)
    # a filter whose innovations are twice as large as it claims leaves the band
    assert monte_carlo([(a, 2 * b, c) for a, b, c in runs])["in_band"] < 0.05
    # a stamp where the runs disagree on the dimension is not averaged
    a, b, c = runs[1]
    c = c.copy()
    c[0] += 2
    assert monte_carlo([runs[0], (a, b, c)] + runs[2:])["t"].size == 199


def test_peak_memory_is_the_cell_process_own():
    """A cell process started from a big parent reports its own peak, not the parent's."""
    import subprocess
    import sys

    from slamarena.experiments.metrics.cost import peak_rss_mb

    ballast = np.ones(300 * 2**20 // 8)  # 300 MiB, touched
    assert peak_rss_mb() > 300
    out = subprocess.run(
        [sys.executable, "-c", "from slamarena.experiments.metrics.cost import peak_rss_mb; print(peak_rss_mb())"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert 5 < float(out.stdout) < 200
    del ballast


def test_series_names_are_the_ones_the_metrics_write(tmp_path):
    """Every name in Series is written by its metric (the cell's flattening), and figures/runner read only those."""
    from slamarena import datasets
    from slamarena.datasets.formats import relations
    from slamarena.datasets.geometry import between
    from slamarena.estimators import create
    from slamarena.experiments.cell import _flatten_series
    from slamarena.experiments.metrics.series import Series

    seq = datasets.load("sim:landmarks", n_landmarks=10, laps=1, seed=0)
    est = create("ekf_slam").run(seq)
    gt = seq.ground_truth
    i = np.arange(0, len(gt.t) - 10, 10)
    delta = between(gt.poses[i], gt.poses[i + 10])
    relations.write(
        tmp_path / "rel.txt",
        relations.Relations(gt.t[i], gt.t[i + 10], np.column_stack([delta[:, :2], np.zeros((len(i), 3)), delta[:, 2]])),
    )
    selected = {name: METRICS[name].params() for name in ("ate", "nees", "nis")} | {
        "relations": METRICS["relations"].params(file=tmp_path / "rel.txt")
    }
    _, series, skipped = evaluate(CellData(est, seq, reference_of(seq)), selected)
    assert not skipped
    assert set(Series) <= set(_flatten_series(series)), set(Series) - set(_flatten_series(series))


def test_estimate_counts_what_the_estimate_reports_of_itself():
    from slamarena.experiments.metrics.estimate import estimate_counts

    t, gt = _truth(K=20)
    filtered = Estimate(
        "ekf_slam",
        t,
        gt,
        landmark_ids=[3, 5, 9],
        landmarks=np.zeros((3, 2)),
        diagnostics={"rejected_nonfinite": np.array(2), "rejected_motion": np.array(1), "nis": np.ones(4)},
        meta={"rejected": 4},
    )
    assert estimate_counts(filtered)[0] == {"landmarks": 3, "rejected": 7}  # 2 + 1 bad rows, 4 refused by the gate
    smoothed = Estimate(
        "gtsam_batch",
        t,
        gt,
        diagnostics={"initial_error": np.array(250.0), "final_error": np.array(12.5), "iterations": np.array(7)},
        meta={"resamplings": 3, "rejected": {"gps": {"gate": 2}}},
    )  # a nested count is not a row count
    assert estimate_counts(smoothed)[0] == {
        "initial_error": 250.0,
        "final_error": 12.5,
        "iterations": 7,
        "resamplings": 3,
    }
    with pytest.raises(MetricUnavailable, match="reports no landmarks"):
        estimate_counts(Estimate("dead_reckoning", t, gt))
