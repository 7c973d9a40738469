"""The measurements of research/notebook/2026-11-28-matcher-wrap.md: the Gauss-Newton matcher's options on laser graph
SLAM's submap front end, MIT-CSAIL's scan 1156, the bicubic covariance with the full Hessian.

Usage (``JSON``: the front end's ``matcher_params``, e.g. ``'{"line_search": true}'``)::

    python research/scripts/matcher_wrap.py front JSON SEED   # hard loop, open-loop front end: ATE, fwd_sum, heading
    python research/scripts/matcher_wrap.py hard JSON [SEED]  # hard loop (tests/mapping/test_laser_slam.py): closed, open
    python research/scripts/matcher_wrap.py drive JSON SEED   # one loop_closure drive, laser graph SLAM: ATE, fwd_sum
    python research/scripts/matcher_wrap.py probe JSON SCAN   # MIT-CSAIL grid SLAM up to SCAN: the match, correlative starts
    python research/scripts/matcher_wrap.py hessian           # the corridor's covariances, Gauss-Newton and full Hessian
    python research/scripts/matcher_wrap.py staged METHOD LOG JSON  # grid_slam / laser_slam on a staged log: relations

``fwd_sum``: the sum over scans of the error of the front end's increment along the robot's x (the along-track drift).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

from slamarena.experiments.config import load_config

#: the hard loop of tests/mapping/test_laser_slam.py (its HARD and FRONT)
HARD = dict(laps=2, k_r=0.1, k_rt=0.03, n_beams=181)
FRONT = dict(frontend={"max_usable_range": 6.0}, loop={"search_every": 2}, tracking="submap")
#: the dataset of experiments/configs/loop_closure.yaml, read from the shipped config
LONG_LOOP = load_config("loop_closure").datasets[0].resolved_params()


def _ate(est, seq, poses=None) -> float:
    from slamarena.datasets.estimate import Estimate
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate

    est = est if poses is None else Estimate(est.method, est.t, poses)
    return float(ate(est, reference_of(seq), ATEParams(align="se2"))[0]["rmse"])


def _increment_errors(poses: np.ndarray, seq) -> np.ndarray:
    """The error of each increment (K − 1, 3) of ``poses`` at the scan stamps against the ground truth's."""
    from slamarena.datasets.geometry import between, wrap_angle

    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    d = between(poses[:-1], poses[1:]) - between(truth[:-1], truth[1:])
    d[:, 2] = wrap_angle(d[:, 2])
    return d


def front(mp: dict, seed: int) -> None:
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = simulate(**HARD, seed=seed)
    params = {**FRONT, "frontend": {**FRONT["frontend"], "matcher_params": mp}}
    est = LaserSLAM(**{**params, "loop": {**FRONT["loop"], "enabled": False}, "refine": {"neighbours": 0}}).run(seq)
    d = _increment_errors(est.poses, seq)
    print(
        f"front {json.dumps(mp)} seed {seed}: open ATE {_ate(est, seq):.4f} m, fwd_sum {d[:, 0].sum():.3f} m, "
        f"heading error per step rms {np.sqrt(np.mean(d[:, 2] ** 2)) * 1e3:.2f} mrad"
    )


def hard(mp: dict, seed: int = 3) -> None:
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = simulate(**HARD, seed=seed)
    params = {**FRONT, "frontend": {**FRONT["frontend"], "matcher_params": mp}}
    closed = LaserSLAM(**params).run(seq)
    open_ = LaserSLAM(**{**params, "loop": {**FRONT["loop"], "enabled": False}, "refine": {"neighbours": 0}}).run(seq)
    print(f"hard {json.dumps(mp)} seed {seed}: closed {_ate(closed, seq):.4f} m, open {_ate(open_, seq):.4f} m")


def drive(mp: dict, seed: int) -> None:
    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam import LaserSLAM

    seq = simulate(**{**LONG_LOOP, "seed": seed})
    cpu = time.process_time()
    est = LaserSLAM(frontend={"matcher_params": mp}).run(seq)
    F = est.diagnostics["front_end_poses"]
    print(
        f"drive {json.dumps(mp)} seed {seed}: ATE {_ate(est, seq):.3f} m, front end {_ate(est, seq, F):.3f} m, "
        f"fwd_sum {_increment_errors(F, seq)[:, 0].sum():.3f} m, loops {est.meta['loop_closures']}, "
        f"cpu {time.process_time() - cpu:.0f} s"
    )


def probe(mp: dict, scan: int) -> None:
    from slamarena import datasets
    from slamarena.mapping import frontend
    from slamarena.mapping.grid_slam import GridSLAM
    from slamarena.mapping.scan_matching import make_matcher

    seq = datasets.load("carmen:mit-csail")
    at, scores = {"k": -1}, []
    beams, match = frontend.FrontEnd.beams, frontend.FrontEnd.match

    class Reached(Exception):
        pass

    def beams_of(self, k):
        at["k"] = k
        return beams(self, k)

    def matched(self, reference, b, guess):
        r = match(self, reference, b, guess)
        if at["k"] == scan:
            print(
                f"scan {scan}: odometry motion {self.motion.round(3)}, guess {guess.round(3)}, match {r.pose.round(3)} "
                f"score {r.score:.3f}; earlier scores ≥ {min(scores):.3f}, 1st percentile "
                f"{np.percentile(scores, 1):.3f}, median {np.median(scores):.3f}"
            )
            for linear, angular in ((0.1, np.radians(20)), (0.1, np.radians(30)), (0.3, np.radians(45))):
                c = make_matcher("correlative", linear_window=linear, angular_window=angular).match(
                    reference, b.points, guess
                )
                f = self.matcher.match(reference, b.points, c.pose)
                print(
                    f"correlative ±{linear} m ±{np.degrees(angular):.0f}°: {c.pose.round(3)} → {f.pose.round(3)} "
                    f"score {f.score:.3f}"
                )
            raise Reached
        if r is not None:
            scores.append(r.score)
        return r

    frontend.FrontEnd.beams, frontend.FrontEnd.match = beams_of, matched
    try:
        GridSLAM(frontend={"matcher_params": mp}).run(seq)
    except Reached:
        pass
    finally:
        frontend.FrontEnd.beams, frontend.FrontEnd.match = beams, match


def hessian() -> None:
    """The corridor of tests/mapping/test_scan_matching.py::test_covariance_is_long_along_a_corridor."""
    from slamarena.mapping.map_pyramid import MapPyramid
    from slamarena.mapping.scan_matching import make_matcher
    from slamarena.mapping.scan_matching.gauss_newton import BICUBIC, BILINEAR, _normal_equations

    corridor = np.array([[-20, -1.0, 20, -1.0], [-20, 1.0, 20, 1.0]]) + 0.013
    full = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    maps = MapPyramid(resolution=0.05, levels=2, size=24.0)
    for x in np.arange(-8.0, 8.1, 1.0):
        pose = np.array([x, 0.0, 0.0])
        maps.integrate(_raycast(pose, full, corridor, 8.0), full, pose, max_range=8.0)
    angles = np.linspace(-1.2, 1.2, 121)
    r = _raycast(np.array([0.2, 0.0, 0.0]), angles, corridor, 4.0)
    ok = r < 4.0
    pts = np.column_stack([r[ok] * np.cos(angles[ok]), r[ok] * np.sin(angles[ok])])
    g = maps.levels[0]
    grid = (g.log_odds, g.origin[0], g.origin[1], g.params.resolution, pts)
    for interpolation, kind in (("bilinear", BILINEAR), ("bicubic", BICUBIC)):
        for line_search in (False, True):
            m = make_matcher("gauss_newton", interpolation=interpolation, line_search=line_search)
            pose = m.match(maps, pts, np.array([0.2, 0.03, 0.0])).pose
            H, _, ssr, _, n = _normal_equations(*grid, *pose, kind)
            Hf = np.zeros((3, 3))
            for j, eps in enumerate((1e-5, 1e-5, 1e-6)):
                e = np.eye(3)[j] * eps
                Hf[:, j] = -(
                    _normal_equations(*grid, *(pose + e), kind)[1] - _normal_equations(*grid, *(pose - e), kind)[1]
                )
                Hf[:, j] /= 2 * eps
            Hf = 0.5 * (Hf + Hf.T)
            block = np.ix_([1, 2], [1, 2])
            for name, A in (("JᵀJ", H), ("full", Hf)):
                C = ssr / (n - 3) * np.linalg.inv(A[block])
                print(
                    f"{interpolation} {'line search' if line_search else 'Hector'} {name}: (y, ψ) block σ_y "
                    f"{np.sqrt(C[0, 0]) * 1e3:.2f} mm σ_ψ {np.sqrt(C[1, 1]) * 1e3:.3f} mrad; eigenvalues "
                    f"{np.round(np.linalg.eigvalsh(A), 1)}"
                )


def _raycast(pose, angles, walls, max_range):
    """Ranges from ``pose`` along ``angles`` to the nearest of the segments ``walls`` (W, 4)."""
    from slamarena.datasets.sim.laser import raycast

    ranges = raycast(pose[None, :2], pose[2] + np.asarray(angles)[None, :], walls, max_range)[0]
    return np.minimum(ranges, max_range)


def staged(method: str, log: str, mp: dict) -> None:
    """``method`` on ``carmen:LOG`` scored by its relations (as research/scripts/degeneracy_2.py), with the number of
    matches whose result came from the correlative search (``search_below_score``)."""
    from slamarena import datasets
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error_from_file
    from slamarena.mapping.grid_slam import GridSLAM
    from slamarena.mapping.laser_slam.slam import LaserSLAM
    from slamarena.mapping.scan_matching.gauss_newton import GaussNewtonMatcher

    searched, match = [0], GaussNewtonMatcher.match

    def counted(self, *args, **kwargs):
        result = match(self, *args, **kwargs)
        searched[0] += result.info.get("from_search", 0)
        return result

    GaussNewtonMatcher.match = counted
    seq = datasets.load(f"carmen:{log}")
    cpu = time.process_time()
    try:
        est = {"grid_slam": GridSLAM, "laser_slam": LaserSLAM}[method](frontend={"matcher_params": mp}).run(seq)
    finally:
        GaussNewtonMatcher.match = match
    relations = RelationsParams(file=f"../shared/datasets/radish_laser_logs/relations/{log}.relations")
    scores, _ = relation_error_from_file(est, seq, relations)
    print(
        f"{method} {log} {json.dumps(mp)}: trans_mean {scores['trans_mean']:.4f} ± {scores['trans_std']:.4f}, "
        f"local {scores['local_trans_mean']:.4f}, from the search {searched[0]}, cpu {time.process_time() - cpu:.0f} s"
    )


def main(argv: list[str]) -> None:
    what = argv[0]
    if what == "hessian":
        hessian()
        return
    if what == "staged":
        staged(argv[1], argv[2], json.loads(argv[3]))
        return
    mp = json.loads(argv[1])
    {"front": front, "hard": hard, "drive": drive, "probe": probe}[what](mp, *map(int, argv[2:]))


if __name__ == "__main__":
    main(sys.argv[1:])
