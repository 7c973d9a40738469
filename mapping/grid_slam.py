"""Scan-to-map laser SLAM on an occupancy-grid pyramid (Hector-style front end), without loop closure.

For each scan k of ``sequence.scans`` the steps of :mod:`slamarena.mapping.frontend`: classify the beams,
guess the pose from odometry, match the usable end points against the one growing map (grid matchers:
gauss_newton, correlative, branch_and_bound, against the grid pyramid; point matchers: kiss_icp,
open3d_icp, against the end points of the last ``reference_scans`` inserted scans), and insert the scan
when the motion filter says so.

Result: :class:`~slamarena.datasets.estimate.Estimate` with one pose per scan at the scan stamps,
``step_time`` the wall time of each scan's steps; ``diagnostics``: ``bad_beams``, ``no_return_beams``,
``usable_beams``, ``matched``, ``map_updated``, ``odometry_stalled``, ``score``, ``iterations``,
``match_cov`` (K, 3, 3; NaN where not matched: the matcher's covariance given the map — with the odometry prior
fused, :mod:`.frontend` — not a full SLAM covariance, hence not ``pose_cov``). After ``run`` the map is ``self.maps`` (a
:class:`~slamarena.mapping.map_pyramid.MapPyramid`) and ``self.map`` its finest grid.
"""

from __future__ import annotations

import time

import numpy as np
from pydantic import PositiveInt

from slamarena.datasets.estimate import Estimate
from slamarena.datasets.geometry import transform_points
from slamarena.datasets.sequence import Sequence
from slamarena.params import Field, Params

from .beams import scan_counts
from .frontend import FrontEnd, FrontEndParams
from .map_pyramid import MapPyramid, PyramidParams
from .scan_matching import make_matcher

__all__ = ["GridSLAM", "GridSLAMParams"]


class GridSLAMParams(Params):
    """Parameters of :class:`GridSLAM` (see the module docstring): the front end (:class:`~.frontend.FrontEndParams`:
    the matcher, the beams used, when the map is updated), the map pyramid and its cell model
    (:class:`~slamarena.mapping.map_pyramid.PyramidParams`; ``cells.hit_guard``: see
    :mod:`slamarena.mapping.occupancy_grid`), and the point matchers' reference."""

    frontend: FrontEndParams = Field(FrontEndParams(), description="the scan-to-map front end")
    pyramid: PyramidParams = Field(PyramidParams(), description="the map pyramid and its cell model")
    reference_scans: PositiveInt = Field(
        10, description="point matchers match against the end points of this many last map-update scans"
    )


class GridSLAM:
    """Scan-to-map SLAM (module docstring; :class:`GridSLAMParams`)."""

    Params = GridSLAMParams

    def __init__(self, params: GridSLAMParams | None = None, /, **overrides):
        self.params = self.Params.of(params, overrides)
        front = self.params.frontend
        self.matcher = make_matcher(front.matcher, **front.matcher_params)  # validated now, rebuilt per run
        self.maps: MapPyramid | None = None

    @property
    def map(self):
        return None if self.maps is None else self.maps.finest

    def run(self, sequence: Sequence, progress=None) -> Estimate:
        """Map ``sequence.scans``; ``progress(k, K)`` is called after each scan when given."""
        scans = sequence.scans
        if scans is None or len(scans) == 0:
            raise ValueError(f"GridSLAM needs a sequence with laser scans; {sequence.name!r} has none")
        K, B = scans.ranges.shape
        p = self.params
        front = FrontEnd(p.frontend, scans)
        self.matcher = front.matcher
        poses = np.zeros((K, 3))
        step_time = np.zeros(K)
        diag = {
            "bad_beams": np.zeros(K, np.int64),
            "no_return_beams": np.zeros(K, np.int64),
            "usable_beams": np.zeros(K, np.int64),
            "matched": np.zeros(K, bool),
            "map_updated": np.zeros(K, bool),
            "score": np.full(K, np.nan),
            "iterations": np.zeros(K, np.int64),
            "match_cov": np.full((K, 3, 3), np.nan),
        }
        pose = front.start_pose(sequence.start_pose)
        self.maps = MapPyramid.around(p.pyramid, pose, min(scans.max_range, p.frontend.clear_range))
        keyframes: list[np.ndarray] = []
        n_beams = np.zeros(K, np.int64)
        for k in range(K):
            t0 = time.perf_counter()
            beams = front.beams(k)
            n_beams[k] = beams.r.size
            diag["bad_beams"][k], diag["no_return_beams"][k], diag["usable_beams"][k] = (
                beams.bad.sum(),
                beams.no_return.sum(),
                beams.usable.sum(),
            )
            pose = front.guess(k, poses, pose)
            if front.last_insert is not None:
                res = front.match(self.maps if front.matcher.kind == "grid" else np.concatenate(keyframes), beams, pose)
                if res is not None:
                    pose = res.pose
                    diag["matched"][k] = True
                    diag["score"][k], diag["iterations"][k], diag["match_cov"][k] = res.score, res.iterations, res.cov
            if len(beams.points) >= p.frontend.min_beams and front.due(pose):
                self.maps.integrate(
                    beams.r[beams.mapped],
                    beams.a[beams.mapped],
                    pose,
                    scans.mount,
                    max_range=front.limit,
                    clear_range=p.frontend.clear_range,
                )
                if front.matcher.kind == "points":
                    keyframes = (keyframes + [transform_points(pose, beams.points)])[-p.reference_scans :]
                front.inserted(pose)
                diag["map_updated"][k] = True
            poses[k] = pose
            step_time[k] = time.perf_counter() - t0
            if progress is not None:
                progress(k + 1, K)
        diag["odometry_stalled"] = front.stalled

        meta = {
            "params": p.canonical(),
            "scans": int(K),
            "beams": int(B),
            **scan_counts(diag, n_beams),
            "odometry_stalled_scans": int(front.stalled.sum()),
            "map_updates": int(diag["map_updated"].sum()),
            "map_shape": list(self.map.shape),
            "map_origin": self.map.origin.tolist(),
        }
        return Estimate(
            method="grid_slam", t=scans.t.copy(), poses=poses, step_time=step_time, diagnostics=diag, meta=meta
        )
