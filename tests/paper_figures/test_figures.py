"""Report figures from a results directory: every kind drawn (PNG + PDF), and their math."""
from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sequence import LandmarkMap, Sequence, Trajectory
from slamarena.experiments.metrics import METRICS, CellData, evaluate, reference_of
from slamarena.experiments.results import cell_dir, save_npz, write_json
from slamarena.paper_figures.scaling import find_sweeps, fit_slope
from slamarena.paper_figures.trajectories import CHI2_2_95, ellipse_points


def _fake_cell(out, label, params, method, seed, n_steps, noise, with_landmarks):
    rng = np.random.default_rng(seed)
    t = np.arange(n_steps) * 0.1
    gt = np.column_stack([5 * np.cos(0.05 * t), 5 * np.sin(0.05 * t), wrap_angle(0.05 * t + np.pi / 2)])
    ids, lm = np.arange(6), np.column_stack([7 * np.cos(np.arange(6)), 7 * np.sin(np.arange(6))])
    seq = Sequence(label, ground_truth=Trajectory(t=t, poses=gt), landmarks=LandmarkMap(ids=ids, xy=lm))
    P = np.diag([noise**2, noise**2, (noise / 5) ** 2])
    est_poses = gt + rng.standard_normal(gt.shape) * [noise, noise, noise / 5]
    kwargs = dict(landmark_ids=ids, landmarks=lm + rng.normal(0, 0.2, lm.shape), landmark_cov=np.broadcast_to(np.diag([0.04, 0.01]), (6, 2, 2))) if with_landmarks else {}
    est = Estimate(method, t, est_poses, pose_cov=np.broadcast_to(P, (n_steps, 3, 3)), step_time=np.full(n_steps, 1e-4 * n_steps), **kwargs)
    selected = {k: METRICS[k].params() for k in ("ate", "nees", "map", "cost")}
    scalars, series, skipped = evaluate(CellData(est, seq, reference_of(seq), wall=1e-4 * n_steps**2, peak_rss=100.0), selected)
    d = cell_dir(out, label, method, seed)
    d.mkdir(parents=True)
    est.save(d / "estimate.npz")
    flat = {f"{m}/{k}": v for m, vals in series.items() for k, v in vals.items() if isinstance(v, np.ndarray)}
    save_npz(d / "series.npz", flat)
    save_npz(d / "truth.npz", {"t": t, "poses": gt, "landmark_ids": ids, "landmarks": lm})
    write_json(d / "metrics.json", {"status": "ok", "dataset": {"label": label, "name": "sim:landmarks", "params": params}, "estimator": {"label": method, "name": method, "params": {}}, "seed": seed, "metrics": scalars, "alignment": series["ate"]["alignment"].as_dict()})


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    for seed in (0, 1):
        _fake_cell(out, "world", {"n_landmarks": 6}, "dead_reckoning", seed, 200, 0.3, False)
        _fake_cell(out, "world", {"n_landmarks": 6}, "ekf_slam", seed, 200, 0.05, True)
    return out


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    for seed in (0, 1):
        _fake_cell(out, "world", {"n_landmarks": 6}, "ekf_slam", seed, 20, 0.05, False)
        for n in (50, 100, 200):
            _fake_cell(out, f"lm{n}", {"n_landmarks": n, "laps": 1}, "ekf_slam", seed, n, 0.05, False)
    return out


def test_every_figure_kind_is_drawn(results, sweep):
    from slamarena.paper_figures.make import make_all

    written, skipped = make_all(results, only=["trajectories", "errors", "nees"], verbose=False)
    assert skipped == {}
    scaling, skipped = make_all(sweep, only=["scaling"], verbose=False)
    assert skipped == {}
    names = {p.name for p in written + scaling}
    for stem in ("trajectories_world", "errors_world", "nees_world", "scaling_sim_landmarks_n_landmarks"):
        assert {f"{stem}.png", f"{stem}.pdf"} <= names
    for p in written + scaling:
        assert p.stat().st_size > 1000
        assert p.read_bytes()[:4] in (b"\x89PNG", b"%PDF")


def test_scaling_sweep_and_slope(sweep):
    from slamarena.paper_figures.runs import load_runs

    sweeps = find_sweeps(load_runs(sweep))
    # "world" differs from the lm* entries in two parameters: not part of the sweep
    assert sweeps == {("sim:landmarks", "n_landmarks"): {"lm50": 50.0, "lm100": 100.0, "lm200": 200.0}}
    x = np.array([10.0, 20.0, 40.0, 80.0])
    b, a = fit_slope(x, 3.0 * x**2)
    assert b == pytest.approx(2.0) and np.exp(a) == pytest.approx(3.0)


def test_ellipse_is_the_95_percent_contour():
    C = np.array([[0.5, 0.2], [0.2, 0.3]])
    m = np.array([1.0, -2.0])
    pts = ellipse_points(m, C)
    d = pts - m
    np.testing.assert_allclose(np.einsum("ni,ij,nj->n", d, np.linalg.inv(C), d), CHI2_2_95)
    assert CHI2_2_95 == pytest.approx(-2 * np.log(0.05))  # χ²₂ is exponential: P(X > x) = exp(−x/2)


def test_nothing_to_draw_is_reported_not_raised(tmp_path):
    from slamarena.paper_figures.make import make_all

    written, skipped = make_all(tmp_path, verbose=False)
    assert written == [] and set(skipped) == {"trajectories", "errors", "nees", "scaling"}
