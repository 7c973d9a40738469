"""Report figures from a results directory: every kind drawn (PNG + PDF + caption), their math, and their style as a
paper's reader sees it (one colour per method across figures, legends off the data, robust axes, paper sizes,
embedded fonts)."""

from __future__ import annotations

import re

import matplotlib.figure
import numpy as np
import pytest
from matplotlib.colors import to_hex

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, wrap_angle
from slamarena.datasets.sequence import LandmarkMap, Sequence, Trajectory
from slamarena.experiments.metrics import METRICS, CellData, evaluate, reference_of
from slamarena.experiments.metrics.relations import relation_error
from slamarena.experiments.results import cell_dir, save_npz, write_json
from slamarena.paper_figures.scaling import crossovers, find_sweeps, fit_slope
from slamarena.paper_figures.style import COLUMN, PAGE, MethodStyles
from slamarena.paper_figures.trajectories import CHI2_2_95, ellipse_points, merged_groups, overlapping

KINDS = ("trajectories", "errors", "nees", "scaling", "relations", "neff", "maps", "vo")


def _world(n_steps):
    t = np.arange(n_steps) * 0.1
    gt = np.column_stack([5 * np.cos(0.05 * t), 5 * np.sin(0.05 * t), wrap_angle(0.05 * t + np.pi / 2)])
    ids, lm = np.arange(6), np.column_stack([7 * np.cos(np.arange(6)), 7 * np.sin(np.arange(6))])
    return Sequence("world", ground_truth=Trajectory(t=t, poses=gt), landmarks=LandmarkMap(ids=ids, xy=lm))


def _write_cell(out, dataset: dict, label, name, seed, est, seq, relations=False):
    selected = {k: METRICS[k].params() for k in ("ate", "nees", "map", "cost")}
    scalars, series, _ = evaluate(
        CellData(est, seq, reference_of(seq), wall=1e-4 * len(est.t) ** 2, peak_rss=100.0), selected
    )
    if relations:  # the relation metric's output on pairs 2 s apart along the ground truth
        gt = seq.ground_truth
        i = np.arange(0, len(gt.t) - 20, 5)
        scalars["relations"], series["relations"] = relation_error(
            est, gt.t[i], gt.t[i + 20], between(gt.poses[i], gt.poses[i + 20])
        )
    d = cell_dir(out, dataset["label"], label, seed)
    d.mkdir(parents=True)
    est.save(d / "estimate.npz")
    save_npz(
        d / "series.npz",
        {f"{m}/{k}": v for m, vals in series.items() for k, v in vals.items() if isinstance(v, np.ndarray)},
    )
    ref = reference_of(seq)
    save_npz(
        d / "truth.npz",
        {
            "t": ref.t,
            "poses": ref.poses,
            **({"landmark_ids": ref.landmark_ids, "landmarks": ref.landmarks} if ref.landmarks is not None else {}),
        },
    )
    write_json(
        d / "metrics.json",
        {
            "status": "ok",
            "dataset": dataset,
            "estimator": {"label": label, "name": name, "params": {}},
            "seed": seed,
            "metrics": scalars,
            "alignment": series["ate"]["alignment"].as_dict(),
        },
    )


def _fake_cell(
    out,
    label,
    params,
    method,
    seed,
    n_steps,
    noise,
    with_landmarks,
    *,
    name=None,
    covariance=True,
    prior_cov=None,
    every=None,
    relations=False,
    diagnostics=None,
    meta=None,
    step_time=None,
):
    """A cell of a method on the circle world: truth plus noise; ``every=(k, r)`` keeps the stamps k·i + r only."""
    rng = np.random.default_rng(seed)
    seq = _world(n_steps)
    gt, t = seq.ground_truth.poses, seq.ground_truth.t
    keep = slice(every[1], None, every[0]) if every else slice(None)
    est_poses = gt + rng.standard_normal(gt.shape) * [noise, noise, noise / 5]
    P = np.broadcast_to(np.diag([noise**2, noise**2, (noise / 5) ** 2]), (n_steps, 3, 3)).copy()
    if prior_cov is not None:  # a prior far wider than the error at t = 0: NEES ≈ 1e-20 there
        P[0] = np.eye(3) * prior_cov
    kwargs = (
        dict(
            landmark_ids=seq.landmarks.ids,
            landmarks=seq.landmarks.xy + rng.normal(0, 0.2, (6, 2)),
            landmark_cov=np.broadcast_to(np.diag([0.04, 0.01]), (6, 2, 2)),
        )
        if with_landmarks
        else {}
    )
    steps = np.full(n_steps, 1e-4 * n_steps) if step_time is None else np.full(n_steps, step_time(n_steps))
    est = Estimate(
        name or method,
        t[keep],
        est_poses[keep],
        pose_cov=P[keep] if covariance else None,
        step_time=steps[keep],
        diagnostics=diagnostics or {},
        meta=meta or {},
        **kwargs,
    )
    _write_cell(
        out,
        {"label": label, "name": "sim:landmarks", "params": params, "simulator": True},
        method,
        name or method,
        seed,
        est,
        seq,
        relations=relations,
    )


def _manifest(out, datasets, methods, published=()):
    write_json(
        out / "manifest.json",
        {
            "experiment": "fake",
            "config": {
                "name": "fake",
                "datasets": [{"name": "sim:landmarks", "label": d} for d in datasets],
                "estimators": [{"name": name, "label": label} for label, name in methods],
                "published": list(published),
            },
        },
    )


#: nine methods, as many as the default experiment: dead reckoning and eight in colour
METHODS = [
    ("dead_reckoning", "dead_reckoning"),
    ("ekf_slam", "ekf_slam"),
    ("no_cov", "ekf_slam"),
    ("ekf_slam_fej", "ekf_slam"),
    ("ekf_localizer", "ekf_localizer"),
    ("ekf_localizer_notes", "ekf_localizer"),
    ("gtsam_batch", "gtsam_batch"),
    ("gtsam_isam2", "gtsam_isam2"),
    ("fastslam", "fastslam"),
]
KUEMMERLE = {
    "label": "Kümmerle et al.",
    "citation": "R. Kümmerle et al., On measuring the accuracy of SLAM algorithms, Auton. Robots 27(4), 2009",
    "values": {"world": {"relations.trans_mean": 0.05, "relations.trans_std": 0.02, "relations.rot_mean": 0.01}},
}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    _manifest(out, ["world"], METHODS, [KUEMMERLE])
    neff = {"neff": np.linspace(30, 5, 50), "neff_t": np.linspace(0, 19.9, 50), "resampled": np.arange(50) % 7 == 0}
    for seed in (0, 1):
        _fake_cell(out, "world", {"n_landmarks": 6}, "dead_reckoning", seed, 200, 0.3, False, relations=True)
        _fake_cell(out, "world", {"n_landmarks": 6}, "ekf_slam", seed, 200, 0.05, True, relations=True)
        _fake_cell(
            out, "world", {"n_landmarks": 6}, "no_cov", seed, 200, 0.05, False, name="ekf_slam", covariance=False
        )
        _fake_cell(
            out, "world", {"n_landmarks": 6}, "ekf_slam_fej", seed, 200, 0.05, True, name="ekf_slam", every=(2, seed)
        )  # seeds share no stamp
        _fake_cell(out, "world", {"n_landmarks": 6}, "ekf_localizer", seed, 200, 0.04, False, name="ekf_localizer")
        _fake_cell(
            out, "world", {"n_landmarks": 6}, "ekf_localizer_notes", seed, 200, 0.06, False, name="ekf_localizer"
        )
        _fake_cell(out, "world", {"n_landmarks": 6}, "gtsam_batch", seed, 200, 0.02, True, prior_cov=1e20)
        _fake_cell(out, "world", {"n_landmarks": 6}, "gtsam_isam2", seed, 200, 0.02, True)
        _fake_cell(
            out,
            "world",
            {"n_landmarks": 6},
            "fastslam",
            seed,
            200,
            0.03,
            True,
            diagnostics=neff,
            meta={"params": {"particles": 30, "resample_threshold": 0.5}},
        )
    return out


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    for seed in (0, 1):
        _fake_cell(out, "world", {"n_landmarks": 6}, "ekf_slam", seed, 20, 0.05, False)
        for n in (50, 100, 200):
            _fake_cell(
                out, f"lm{n}", {"n_landmarks": n, "laps": 1}, "ekf_slam", seed, n, 0.05, False
            )  # step time 1e-4 n
            _fake_cell(
                out,
                f"lm{n}",
                {"n_landmarks": n, "laps": 1},
                "gtsam_isam2",
                seed,
                n,
                0.05,
                False,
                step_time=lambda n: 1e-3 * n**0.5,
            )
    return out


@pytest.fixture(scope="module")
def laser(tmp_path_factory):
    """laser_slam (before and after loop closure, loops) and dead reckoning on the simulated laser world."""
    from slamarena import datasets

    out = tmp_path_factory.mktemp("laser")
    seq = datasets.load("sim:laser", seed=0)
    gt, t = seq.ground_truth.poses, seq.ground_truth.t
    scan_poses = np.column_stack(
        [np.interp(seq.scans.t, t, gt[:, k]) for k in (0, 1)] + [np.interp(seq.scans.t, t, np.unwrap(gt[:, 2]))]
    )
    drift = np.column_stack(
        [np.linspace(0, 0.8, len(scan_poses)), np.zeros(len(scan_poses)), np.linspace(0, 0.05, len(scan_poses))]
    )
    nodes = np.arange(0, len(scan_poses), 5)
    diag = {
        "front_end_poses": scan_poses + drift,
        "node_scan": nodes,
        "loop_node": np.array([len(nodes) - 1, len(nodes) - 2, 10]),
        "loop_anchor": np.array([0, 1, 3]),
        "loop_accepted": np.array([True, True, False]),
    }
    dataset = {"label": "laser", "name": "sim:laser", "params": {}, "simulator": True}
    _write_cell(
        out,
        dataset,
        "laser_slam",
        "laser_slam",
        0,
        Estimate("laser_slam", seq.scans.t, scan_poses, diagnostics=diag),
        seq,
    )
    _write_cell(
        out,
        dataset,
        "dead_reckoning",
        "dead_reckoning",
        0,
        Estimate("dead_reckoning", seq.scans.t, scan_poses + 2 * drift),
        seq,
    )
    return out


@pytest.fixture(scope="module")
def drawn(results, sweep, laser):
    """Every figure of the three results directories, with what a reader sees of each (recorded as it is saved)."""
    from slamarena.paper_figures.make import make_all

    seen = {}
    original = matplotlib.figure.Figure.savefig

    def record(fig, path, *args, **kwargs):
        match = re.fullmatch(r"\.(.+)\.\d+\.tmp\.(png|pdf)", path.name)  # style.save's temporary name
        stem = match.group(1)
        if stem not in seen:
            fig.canvas.draw()
            renderer = fig.canvas.get_renderer()
            axes = [ax for ax in fig.axes if ax.get_visible()]
            seen[stem] = {
                "size": tuple(fig.get_size_inches()),
                "axes": axes,
                "titles": [ax.get_title() for ax in axes],
                "ylims": [ax.get_ylim() for ax in axes],
                "lines": [
                    (line.get_label(), to_hex(line.get_color()), line.get_linestyle())
                    for ax in axes
                    for line in ax.get_lines()
                    if not line.get_label().startswith("_")
                ],
                "legends": [
                    leg.get_window_extent(renderer)
                    for leg in [*fig.legends, *(ax.get_legend() for ax in axes if ax.get_legend())]
                ],
                "axes_boxes": [ax.get_window_extent(renderer) for ax in axes],
                "legend_labels": [t.get_text() for leg in fig.legends for t in leg.get_texts()],
            }
        return original(fig, path, *args, **kwargs)

    mp = pytest.MonkeyPatch()
    mp.setattr(matplotlib.figure.Figure, "savefig", record)
    try:
        files = {}
        for directory, kinds in ((results, None), (sweep, ["scaling"]), (laser, ["trajectories", "maps"])):
            files[directory] = make_all(directory, only=kinds, verbose=False)
    finally:
        mp.undo()
    return seen, files


def test_every_figure_kind_is_drawn_with_its_caption(drawn, results, sweep, laser):
    seen, files = drawn
    assert files[results][1].keys() == {"scaling", "maps", "vo"}  # no sweep, no laser mapping method, no camera
    assert files[sweep][1] == files[laser][1] == {}
    names = {p.name for written, _ in files.values() for p in written}
    for stem in (
        "trajectories_world",
        "errors_world",
        "nees_world",
        "relations_world",
        "relations",
        "neff_world",
        "maps_laser",
        "scaling_sim_landmarks_n_landmarks",
    ):
        assert {f"{stem}.png", f"{stem}.pdf"} <= names, stem
    for written, _ in files.values():
        for p in written:
            assert p.stat().st_size > 1000
            assert p.read_bytes()[:4] in (b"\x89PNG", b"%PDF")
            assert len(p.with_suffix(".caption").read_text().strip()) > 40, p


def test_one_colour_per_method_in_every_figure_of_a_run(drawn):
    """Nine methods (the default experiment has nine): no two share a colour and line style, and each keeps its
    own in every figure, including the NEES figure, which has no panel for ``no_cov``."""
    seen, _ = drawn
    labels = {label for label, _ in METHODS}
    styles: dict[str, set] = {}
    for stem in ("trajectories_world", "errors_world", "nees_world", "relations_world", "relations", "neff_world"):
        for label, colour, linestyle in seen[stem]["lines"]:
            if label in labels:
                styles.setdefault(label, set()).add((colour, linestyle))
    assert all(len(s) == 1 for s in styles.values()), styles
    pairs = [next(iter(s)) for s in styles.values()]
    assert len(set(pairs)) == len(pairs) == len(labels), styles


def test_method_styles_follow_the_config_order_and_never_repeat():
    methods = [("dead_reckoning", "dead_reckoning")] + [(f"m{k}", "ekf_slam") for k in range(20)]
    styles = MethodStyles(methods)
    pairs = [(styles(m)["color"], styles(m)["linestyle"]) for m, _ in methods]
    assert len(set(pairs)) == len(pairs)
    assert styles("dead_reckoning")["linestyle"] == "--" and styles("m0")["linestyle"] == "-"
    assert MethodStyles(methods[:3])("m1") == styles("m1")  # the palette does not depend on how many methods follow


def test_legends_never_cover_the_data(drawn):
    seen, _ = drawn
    for stem, fig in seen.items():
        assert fig["legends"], stem
        for legend in fig["legends"]:
            for box in fig["axes_boxes"]:
                assert not legend.overlaps(box), (stem, legend, box)


def test_nees_axis_is_not_stretched_by_a_near_zero_prior_and_panels_only_for_methods_with_a_nees(drawn):
    seen, _ = drawn
    nees = seen["nees_world"]
    titles = [t.split(":")[0] for t in nees["titles"]]
    assert "no_cov" not in titles  # no covariance: no NEES
    assert "ekf_slam_fej" not in titles  # seeds that share no stamp have no Monte Carlo average
    assert {"dead_reckoning", "ekf_slam", "gtsam_batch", "gtsam_isam2", "fastslam"} <= set(titles)
    lo, hi = nees["ylims"][titles.index("gtsam_batch")]
    assert 1e-2 < lo < 0.5 and hi < 30  # the 1e-20 at t = 0 is off the axis, the band [0.6, 6.2] on it


def test_overlapping_trajectories_get_an_error_panel():
    t = np.linspace(0, 10, 101)
    circle = np.column_stack([10 * np.cos(t / 2), 10 * np.sin(t / 2)])
    curves = {"truth": (t, circle), "a": (t, circle + 0.05), "b": (t[::2], circle[::2] + 3.0)}
    assert overlapping(curves, extent=20.0) == [("truth", "a")]


def test_trajectory_figure_adds_the_error_panel_where_estimates_overlap(drawn):
    seen, _ = drawn
    traj = seen["trajectories_world"]
    assert len(traj["axes"]) == 2 and traj["axes"][1].get_yscale() == "log"


def test_merged_groups_name_each_curve_once():
    pairs = [("truth", "a"), ("b", "c"), ("a", "d"), ("c", "e"), ("truth", "d"), ("d", "b"), ("f", "g")]
    assert merged_groups(pairs) == [["truth", "a", "d", "b", "c", "e"], ["f", "g"]]
    assert merged_groups([]) == []


def test_trajectory_caption_names_the_merged_curves_once_not_every_pair(results, drawn):
    caption = (results / "figures" / "trajectories_world.caption").read_text()
    panel = caption.split("Lower panel:")[1]
    names = re.findall(r"[\w ]+", panel.split(":", 1)[1])
    curves = [n.strip() for n in names if n.strip()]
    assert len(curves) == len(set(curves)) >= 3, panel  # each curve once
    assert " and " not in panel.split(":", 1)[1]  # no pair-by-pair list


def test_sizes_fit_a_paper_and_fonts_are_embedded(drawn):
    seen, files = drawn
    widths = {round(fig["size"][0], 2) for fig in seen.values()}
    assert widths <= {COLUMN, PAGE}, widths
    for written, _ in files.values():
        for pdf in (p for p in written if p.suffix == ".pdf"):
            data = pdf.read_bytes()
            width = float(re.search(rb"/MediaBox \[ *0 0 ([\d.]+) ", data).group(1))
            assert width in (pytest.approx(COLUMN * 72), pytest.approx(PAGE * 72)), (pdf.name, width)
            assert b"/FontFile2" in data and b"/Type3" not in data, pdf.name  # TrueType, embedded


def test_new_figures_show_what_they_say(drawn):
    seen, _ = drawn
    assert "Kümmerle et al. (published)" in seen["relations"]["legend_labels"]
    assert {"resampling threshold", "fastslam"} <= {label for label, _, _ in seen["neff_world"]["lines"]}
    maps = seen["maps_laser"]
    assert maps["titles"] == [
        "ground truth",
        "dead_reckoning",
        "laser_slam, before loop closure",
        "laser_slam, after loop closure",
    ]
    assert (
        sum(label == "accepted loop closure" for label, _, _ in maps["lines"]) == 2
    )  # the rejected candidate is not drawn


def test_maps_of_a_dataset_this_machine_cannot_load_are_skipped_with_the_reason(laser, tmp_path):
    import json
    import shutil

    from slamarena.paper_figures.make import make_all

    copy = tmp_path / "copied"
    shutil.copytree(laser, copy, ignore=shutil.ignore_patterns("figures"))
    for path in copy.glob("runs/*/*/*/metrics.json"):
        info = json.loads(path.read_text())
        info["dataset"]["name"] = "sim:elsewhere"
        path.write_text(json.dumps(info))
    written, skipped = make_all(copy, only=["maps"], verbose=False)
    assert written == [] and skipped["maps"].startswith("laser: ") and "sim:elsewhere" in skipped["maps"]


def test_scaling_sweep_slope_and_crossover(sweep, drawn):
    from slamarena.paper_figures.runs import load_runs

    sweeps = find_sweeps(load_runs(sweep))
    # "world" differs from the lm* entries in two parameters: not part of the sweep
    assert sweeps == {("sim:landmarks", "n_landmarks"): {"lm50": 50.0, "lm100": 100.0, "lm200": 200.0}}
    x = np.array([10.0, 20.0, 40.0, 80.0])
    b, a = fit_slope(x, 3.0 * x**2)
    assert b == pytest.approx(2.0) and np.exp(a) == pytest.approx(3.0)
    ((slower, faster, x_star),) = crossovers({"isam2": (0.5, np.log(1e-3)), "ekf": (1.0, np.log(1e-4))})
    assert (slower, faster) == ("ekf", "isam2") and x_star == pytest.approx(100.0)  # 1e-4 n = 1e-3 √n
    caption = (sweep / "figures" / "scaling_sim_landmarks_n_landmarks.caption").read_text()
    assert "ekf_slam passes gtsam_isam2 at n_landmarks ≈ 100" in caption
    assert "crossover of two fits" in seen_labels(drawn, "scaling_sim_landmarks_n_landmarks")


def seen_labels(drawn, stem):
    return {label for label, _, _ in drawn[0][stem]["lines"]}


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
    assert written == [] and set(skipped) == set(KINDS)


def test_exponent_labels_keep_their_order_and_a_gap_and_move_only_when_crowded():
    from slamarena.paper_figures.scaling import spread

    far = np.array([0.0, 1.0, -2.0])
    np.testing.assert_array_equal(spread(far, 0.1), far)  # far apart: where the lines end
    close = np.array([1.00, 1.02, -3.0, 1.01])
    at = spread(close, 0.1)
    order = np.argsort(close, kind="stable")
    assert np.all(np.diff(at[order]) >= 0.1 - 1e-12)  # spaced by the gap, in the lines' order
    assert at[2] == -3.0  # the lone label does not move
    assert np.mean(at[[0, 1, 3]]) == pytest.approx(np.mean(close[[0, 1, 3]]))  # the crowd is centred where it was
