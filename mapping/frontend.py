"""The scan-to-map front end shared by grid SLAM and laser graph SLAM: beams, the odometry guess, the match,
and the motion filter that decides when a scan is inserted into a map.

For scan k (robot pose ``x_k = (x, y, θ)``):

1. Beams (:meth:`FrontEnd.beams`). Scan k's beams and angles come from ``Scans.beams(k)`` (interlaced logs:
   each scan's own angle offset and beam count). A reading is *bad* when it is NaN, ±inf, zero or negative
   (rejected, counted); *no return* when ``≥ max_range`` (clears space only); *usable* otherwise (and below
   ``max_usable_range`` when set). End points of the usable beams in the robot frame:
   ``s_i = mount ⊕ (r_i cos α_i, r_i sin α_i)``.
2. Guess (:meth:`FrontEnd.guess`). With odometry poses ``o_k``: ``x̂_k = x_j ⊕ (⊖o_j ⊕ o_k)`` with j the
   last scan whose reading was *fresh* (different from the one before it); a reading equal to the previous
   one carries no motion (``x̂_k = x_{k−1}``, counted as stalled). On most logs j = k − 1 and this is the
   odometry increment applied to the previous estimate; mit-csail's odometry freezes for four scans while
   the robot moves and then jumps by the whole motion (scans 321–325, 798–802, 1580–1584): the matcher has
   already followed that motion, and applying the jump to x_{k−1} would count it twice. Without odometry:
   ``x̂_k = x_{k−1}``.
3. Match (:meth:`FrontEnd.match`): with at least ``min_beams`` usable beams, ``x_k = matcher.match(map, s,
   x̂_k).pose``; else ``x_k = x̂_k`` (not matched). When the guess applied an odometry motion, a matcher that
   ``takes_odometry`` (Gauss-Newton) keeps the directions the scan does not constrain at the guess, and its
   covariance shows them (:mod:`~slamarena.mapping.scan_matching.gauss_newton`, "Degeneracy";
   research/method/laser_degeneracy.md).
4. Motion filter (:meth:`FrontEnd.due`): a scan is inserted into the map while the map holds fewer than
   ``initial_updates`` scans, then when the pose moved more than ``update_distance`` or turned more than
   ``update_angle`` since the last insertion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import NonNegativeFloat, NonNegativeInt, PositiveFloat, ValidationInfo, field_validator

from slamarena.datasets.geometry import between, compose, transform_points, wrap_angle
from slamarena.datasets.sequence import Scans
from slamarena.params import Field, Params, params_model

from .beams import classify
from .scan_matching import MATCHERS, MatchResult, make_matcher, matcher_class

__all__ = ["FrontEnd", "FrontEndParams", "ScanBeams"]


class FrontEndParams(Params):
    """The front end's parameters (module docstring): the matcher, the beams used, and when a scan is inserted (the
    ``frontend`` of grid SLAM's and laser graph SLAM's parameters).

    ``matcher_params`` are validated by the matcher's own model (``MatcherClass.Params``) and kept in its
    canonical form, every default filled in: a wrong matcher parameter in an experiment config fails before
    any cell runs, naming ``params.frontend.matcher_params.<field>``.

    ``update_distance``, ``update_angle``: Hector's 0.4 m, 0.9 rad. ``initial_updates``: a one-scan map is
    sparse at grazing angles and the Gauss-Newton match against it can jump by a cell (the notes' "10–20 scans
    before scan matching"). ``clear_range``: 5 m, Cartographer's missing_data_ray_length: no-returns of real
    lasers also come from glass and dark surfaces, and long clearing rays erase walls they pass.
    """

    matcher: Literal[tuple(MATCHERS)] = Field(
        "gauss_newton", description="scan matcher, a name of slamarena.mapping.scan_matching.MATCHERS"
    )
    matcher_params: dict[str, Any] = Field(
        default_factory=dict,
        description="the matcher's parameters (its Params model)",
        json_schema_extra={"model": "matcher_model"},  # the attribute that gives them as that model
    )
    use_odometry: bool = Field(
        True, description="guess each pose from the scans' odometry poses (else: the previous pose)"
    )
    update_distance: NonNegativeFloat = Field(
        0.4, description="update the map when the pose moved more than this since the last update [m]"
    )
    update_angle: NonNegativeFloat = Field(
        0.9, description="update the map when the pose turned more than this since the last update [rad]"
    )
    initial_updates: NonNegativeInt = Field(
        10, description="update the map at every usable scan until it holds this many scans"
    )
    clear_range: PositiveFloat = Field(5.0, description="how far a no-return reading clears space [m]")
    max_usable_range: PositiveFloat | None = Field(
        None, description="longer returns are neither matched nor mapped [m]; None: all returns"
    )
    min_beams: int = Field(10, ge=3, description="fewest usable beams for a match")

    @property
    def matcher_model(self) -> Params:
        """``matcher_params`` as the matcher's own parameter model."""
        return params_model(matcher_class(self.matcher)).of(self.matcher_params)

    @field_validator("matcher_params")
    @classmethod
    def _matcher_params(cls, value: dict, info: ValidationInfo) -> dict:
        if "matcher" not in info.data:  # the matcher's name is wrong: reported on its own
            return value
        return params_model(matcher_class(info.data["matcher"])).of(value).canonical()


@dataclass
class ScanBeams:
    """One scan's beams: ranges r and angles a (B,), masks bad / no_return / usable (B,), and the usable end
    points in the robot frame ``points`` (N, 2)."""

    r: np.ndarray
    a: np.ndarray
    bad: np.ndarray
    no_return: np.ndarray
    usable: np.ndarray
    points: np.ndarray

    @property
    def mapped(self) -> np.ndarray:
        """The beams a map insertion uses: usable returns and no-returns (which clear space)."""
        return self.usable | self.no_return


class FrontEnd:
    """The per-scan steps of the module docstring for one log (:class:`FrontEndParams`)."""

    def __init__(self, params: FrontEndParams, scans: Scans):
        self.params = params
        self.scans = scans
        self.matcher = make_matcher(params.matcher, **params.matcher_params)
        self.odom = scans.pose if (params.use_odometry and scans.pose is not None) else None
        self.limit = (
            scans.max_range if params.max_usable_range is None else min(scans.max_range, params.max_usable_range)
        )
        self._fresh = 0
        self.odometry_guess = False
        self.motion: np.ndarray | None = None
        self.stalled = np.zeros(len(scans), dtype=bool)
        self.last_insert: np.ndarray | None = None
        self.insertions = 0

    def start_pose(self, fallback: np.ndarray) -> np.ndarray:
        """The first scan's odometry pose when it has one, else ``fallback``."""
        pose = (
            self.scans.pose[0] if self.scans.pose is not None and np.all(np.isfinite(self.scans.pose[0])) else fallback
        )
        return np.asarray(pose, dtype=float).copy()

    def beams(self, k: int) -> ScanBeams:
        r, a = self.scans.beams(k)
        bad, no_return, usable = classify(r, self.scans.max_range, self.limit)
        points = transform_points(
            self.scans.mount, np.column_stack([r[usable] * np.cos(a[usable]), r[usable] * np.sin(a[usable])])
        )
        return ScanBeams(r, a, bad, no_return, usable, points)

    def guess(self, k: int, estimates: np.ndarray, previous: np.ndarray) -> np.ndarray:
        """x̂_k from the estimates of the scans before k (indexable by scan) and the previous pose; ``odometry_guess``
        becomes whether it applied an odometry motion, ``motion`` (3,) the odometry's motion since scan k − 1 (zero
        when the reading is stalled; None when the odometry says nothing: none, non-finite, or k = 0)."""
        odom = self.odom
        self.odometry_guess = False
        self.motion = None
        if k == 0 or odom is None or not (np.all(np.isfinite(odom[k])) and np.all(np.isfinite(odom[k - 1]))):
            return previous
        if np.array_equal(odom[k], odom[k - 1]):
            self.stalled[k] = True
            self.motion = np.zeros(3)
            return previous
        j, self._fresh = self._fresh, k
        if not np.all(np.isfinite(odom[j])):
            j = k - 1
        self.odometry_guess = True
        self.motion = between(odom[j], odom[k])
        return compose(estimates[j], self.motion)

    def match(self, reference, beams: ScanBeams, guess: np.ndarray) -> MatchResult | None:
        """The matcher's result against ``reference`` (a map pyramid, or end points for point matchers); None
        when the scan has too few usable beams."""
        if len(beams.points) < self.params.min_beams:
            return None
        if self.matcher.takes_odometry and self.odometry_guess:
            return self.matcher.match(reference, beams.points, guess, odometry=True)
        return self.matcher.match(reference, beams.points, guess)

    def due(self, pose: np.ndarray) -> bool:
        """Whether the scan at ``pose`` is inserted (the motion filter)."""
        p = self.params
        last = self.last_insert
        return (
            last is None
            or self.insertions < p.initial_updates
            or np.hypot(*(pose[:2] - last[:2])) > p.update_distance
            or abs(wrap_angle(pose[2] - last[2])) > p.update_angle
        )

    def inserted(self, pose: np.ndarray) -> None:
        """Note that the scan at ``pose`` was inserted."""
        self.last_insert = pose.copy()
        self.insertions += 1
