"""Scan-to-map laser SLAM on an occupancy-grid pyramid (Hector-style front end).

For each scan k of ``sequence.scans`` (robot pose ``x_k = (x, y, θ)``, world frame):

1. Beams. Scan k's beams and angles come from ``Scans.beams(k)`` (interlaced logs: each scan's
   own angle offset and beam count; the padding of shorter scans is not a beam). A reading is
   *bad* when it is NaN, ±inf, zero or negative (rejected, counted per scan in
   ``diagnostics["bad_beams"]``); *no return* when ``≥ max_range`` (clears space only);
   *usable* otherwise (and below ``max_usable_range`` when set). End points of usable beams in
   the robot frame: ``s_i = mount ⊕ (r_i cos α_i, r_i sin α_i)``.
2. Guess. With odometry (``use_odometry`` and ``Scans.pose`` present):
   ``x̂_k = x_{k−1} ⊕ (⊖o_{k−1} ⊕ o_k)`` (the odometry increment applied to the previous
   estimate); without: ``x̂_k = x_{k−1}``.
3. Match. If the scan has fewer than ``min_beams`` usable beams it is not matched
   (``x_k = x̂_k``; ``diagnostics["matched"] = False``; "all max-range" scans land here), else
   ``x_k = matcher.match(map, s, x̂_k).pose``. Grid matchers (gauss_newton, correlative,
   branch_and_bound) match against the grid pyramid, point matchers (kiss_icp,
   open3d_icp) against the end points of the last ``reference_scans`` map-update scans.
4. Map update: each of the first ``initial_updates`` usable scans, then whenever the pose
   moved more than ``update_distance`` [m] or turned more than ``update_angle`` [rad] since
   the last update.

Result: :class:`~slamarena.datasets.estimate.Estimate` with one pose per scan at the scan stamps,
``step_time`` the wall time of each scan's steps 1–4; ``diagnostics``: ``bad_beams``,
``no_return_beams``, ``usable_beams``, ``matched``, ``map_updated``, ``score``,
``iterations``, ``match_cov`` (K, 3, 3; NaN where not matched: the matcher's covariance
given the map, not a full SLAM covariance, hence not ``pose_cov``). After ``run`` the map is
``self.maps`` (a :class:`~slamarena.mapping.map_pyramid.MapPyramid`) and ``self.map`` its finest grid.
"""
from __future__ import annotations

import time

import numpy as np

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import between, compose, transform_points, wrap_angle
from slamarena.datasets.sequence import Sequence

from .map_pyramid import MapPyramid
from .scan_matching import MATCHERS, make_matcher

__all__ = ["GridSLAM"]


class GridSLAM:
    """Scan-to-map SLAM; every parameter is a keyword with a default (see the module docstring).

    matcher: a name of :data:`slamarena.mapping.scan_matching.MATCHERS`; matcher_params: its keywords.
    resolution [m], levels: the map pyramid. update_distance [m], update_angle [rad]: map
    update thresholds (Hector's 0.4 m, 0.9 rad). p_hit, p_miss, clamp, hit_guard: the cell
    model (hit_guard g > 0: cells within g cells of a hit are not cleared by the same scan,
    see :mod:`slamarena.mapping.occupancy_grid`). initial_updates: the map is updated at every one of
    the first scans until it holds this many (a one-scan map is sparse at grazing angles and
    the Gauss-Newton match against it can jump by a cell; the notes' "10–20 scans before
    scan matching").
    clear_range [m]: how far a no-return reading clears space (5 m, Cartographer's
    missing_data_ray_length: no-returns of real lasers also come from glass and dark
    surfaces, and long clearing rays erase walls they pass). max_usable_range [m]: longer
    returns are not matched or mapped (None: all returns). min_beams: fewest usable beams
    for a match. reference_scans: point matchers' reference size. use_odometry: guess from
    the scans' odometry poses.
    """

    def __init__(
        self,
        matcher: str = "gauss_newton",
        matcher_params: dict | None = None,
        use_odometry: bool = True,
        resolution: float = 0.05,
        levels: int = 3,
        update_distance: float = 0.4,
        update_angle: float = 0.9,
        p_hit: float = 0.7,
        p_miss: float = 0.4,
        clamp: list | tuple | None = (0.12, 0.97),
        hit_guard: int = 0,
        clear_range: float = 5.0,
        max_usable_range: float | None = None,
        min_beams: int = 10,
        reference_scans: int = 10,
        initial_updates: int = 10,
    ):
        if matcher not in MATCHERS:
            raise ValueError(f"unknown matcher {matcher!r}; known: {', '.join(MATCHERS)}")
        if resolution <= 0 or levels < 1 or update_distance < 0 or update_angle < 0 or clear_range <= 0 or min_beams < 3 or reference_scans < 1:
            raise ValueError("GridSLAM: resolution > 0, levels ≥ 1, thresholds ≥ 0, clear_range > 0, min_beams ≥ 3, reference_scans ≥ 1")
        if max_usable_range is not None and max_usable_range <= 0:
            raise ValueError("max_usable_range must be > 0")
        self.matcher_name = matcher
        self.matcher_params = dict(matcher_params or {})
        self.matcher = make_matcher(matcher, **self.matcher_params)
        self.use_odometry = bool(use_odometry)
        self.grid_params = dict(resolution=float(resolution), levels=int(levels), p_hit=p_hit, p_miss=p_miss,
                                clamp=None if clamp is None else tuple(clamp), hit_guard=int(hit_guard))
        self.update_distance, self.update_angle = float(update_distance), float(update_angle)
        self.clear_range, self.max_usable_range = float(clear_range), max_usable_range
        self.min_beams, self.reference_scans = int(min_beams), int(reference_scans)
        if initial_updates < 0:
            raise ValueError("initial_updates must be ≥ 0")
        self.initial_updates = int(initial_updates)
        self.maps: MapPyramid | None = None

    @property
    def map(self):
        return None if self.maps is None else self.maps.finest

    def params(self) -> dict:
        return {"matcher": self.matcher_name, "matcher_params": self.matcher_params, "use_odometry": self.use_odometry,
                **self.grid_params, "update_distance": self.update_distance, "update_angle": self.update_angle,
                "clear_range": self.clear_range, "initial_updates": self.initial_updates, "max_usable_range": self.max_usable_range, "min_beams": self.min_beams,
                "reference_scans": self.reference_scans}

    def run(self, sequence: Sequence, progress=None) -> Estimate:
        """Map ``sequence.scans``; ``progress(k, K)`` is called after each scan when given."""
        scans = sequence.scans
        if scans is None or len(scans) == 0:
            raise ValueError(f"GridSLAM needs a sequence with laser scans; {sequence.name!r} has none")
        K, B = scans.ranges.shape
        odom = scans.pose if (self.use_odometry and scans.pose is not None) else None
        limit = scans.max_range if self.max_usable_range is None else min(scans.max_range, self.max_usable_range)

        poses = np.zeros((K, 3))
        step_time = np.zeros(K)
        diag = {
            "bad_beams": np.zeros(K, np.int64), "no_return_beams": np.zeros(K, np.int64), "usable_beams": np.zeros(K, np.int64),
            "matched": np.zeros(K, bool), "map_updated": np.zeros(K, bool), "score": np.full(K, np.nan),
            "iterations": np.zeros(K, np.int64), "match_cov": np.full((K, 3, 3), np.nan),
        }
        start = scans.pose[0] if scans.pose is not None and np.all(np.isfinite(scans.pose[0])) else sequence.start_pose
        pose = np.asarray(start, dtype=float).copy()
        self.maps = MapPyramid(**self.grid_params, size=2.0 * min(scans.max_range, self.clear_range, 50.0), centre=pose[:2])
        last_update = None
        n_updates = 0
        keyframes: list[np.ndarray] = []
        n_beams = np.zeros(K, np.int64)
        for k in range(K):
            t0 = time.perf_counter()
            r, a = scans.beams(k)
            n_beams[k] = r.size
            finite = np.isfinite(r)
            bad = ~finite | (np.where(finite, r, 1.0) <= 0)
            no_return = ~bad & (r >= scans.max_range)
            usable = ~bad & (r < limit)
            diag["bad_beams"][k], diag["no_return_beams"][k], diag["usable_beams"][k] = bad.sum(), no_return.sum(), usable.sum()

            if k > 0 and odom is not None and np.all(np.isfinite(odom[k - 1 : k + 1])):
                pose = compose(pose, between(odom[k - 1], odom[k]))
            if usable.sum() >= self.min_beams:
                pts = transform_points(scans.mount, np.column_stack([r[usable] * np.cos(a[usable]), r[usable] * np.sin(a[usable])]))
                if last_update is not None:
                    reference = self.maps if self.matcher.kind == "grid" else np.concatenate(keyframes)
                    res = self.matcher.match(reference, pts, pose)
                    pose = res.pose
                    diag["matched"][k] = True
                    diag["score"][k], diag["iterations"][k], diag["match_cov"][k] = res.score, res.iterations, res.cov
                if last_update is None or n_updates < self.initial_updates or np.hypot(*(pose[:2] - last_update[:2])) > self.update_distance or abs(wrap_angle(pose[2] - last_update[2])) > self.update_angle:
                    mapped = ~bad & ((r < limit) | no_return)
                    self.maps.integrate(r[mapped], a[mapped], pose, scans.mount, max_range=limit, clear_range=self.clear_range)
                    if self.matcher.kind == "points":
                        keyframes = (keyframes + [transform_points(pose, pts)])[-self.reference_scans :]
                    last_update = pose.copy()
                    n_updates += 1
                    diag["map_updated"][k] = True
            poses[k] = pose
            step_time[k] = time.perf_counter() - t0
            if progress is not None:
                progress(k + 1, K)

        meta = {
            "params": self.params(),
            "scans": int(K),
            "beams": int(B),
            "bad_beams": int(diag["bad_beams"].sum()),
            "scans_with_bad_beams": int((diag["bad_beams"] > 0).sum()),
            "scans_not_matched": int((~diag["matched"]).sum()),
            "scans_all_no_return": int((diag["no_return_beams"] + diag["bad_beams"] == n_beams).sum()),
            "scans_all_bad": int((diag["bad_beams"] == n_beams).sum()),
            "map_updates": int(diag["map_updated"].sum()),
            "map_shape": list(self.map.shape),
            "map_origin": self.map.origin.tolist(),
        }
        return Estimate(method="grid_slam", t=scans.t.copy(), poses=poses, step_time=step_time, diagnostics=diag, meta=meta)
