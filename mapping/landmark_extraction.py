"""Landmarks from raw 2D laser scans: range-bearing observations of beacons and poles, with covariances.

Input: :class:`~slamarena.datasets.sequence.Scans` — ranges (S, B) [m] at beam angles (B,) [rad] (uniform step Δθ,
counter-clockwise, in the sensor frame), a no-return code ``max_range`` and, where the sensor gives them,
intensities (S, B). Output: :class:`Detections` in the sensor frame, and (:func:`landmark_sequence`) the
sequence with a :class:`~slamarena.datasets.sequence.RangeBearing` stream in the robot frame (ids −1: unknown).
Everything is vectorised over all beams of all scans at once; no loop over scans or segments.

**Segments.** A beam is *valid* when its range is finite, in ``[min_range, max_range]`` and below the sensor's
no-return code. A run of consecutive valid beams is one segment until the range jumps between neighbours,
``|r_{i+1} − r_i| > jump``; for ``features="beacons"`` only *bright* beams (intensity ≥ ``intensity_min``) are
members, so a segment is a run of bright beams without a jump, and runs of one scan separated by at most ``bridge``
beams whose facing ends differ by at most ``jump`` are joined (near a beacon its reflection drops out on single beams:
the car park's beacons at 2 m show bright beams 17 and 20 with dark ones between); a joined segment's front range is
the mean of its bright beams. A segment of n beams, first f and last l:

* front range ``r_f``: the mean of the range(s) of its middle beam(s) (one for odd n, two for even; ``m`` beams);
* bearing ``β = (θ_f + θ_l)/2``, the centre of its angular extent;
* the centre's range ``r``: a feature is a circle of radius ρ (below); a middle beam i at ``δ_i = θ_i − β`` from the
  centre meets it at ``r_i``, so ``r_c = r_i cos δ_i + √(ρ² − r_i² sin² δ_i)`` (root clamped at 0), averaged over the
  middle beams, less the mean depth ``E[u²]/(2ρ)`` at which a beam off the apex by ``u = r e_β`` meets the circle,
  ``e_β`` the bearing's quantisation error (variance v_β, below): ``E[u²] = min(r² v_β, ρ²/3)`` (a beam meets the
  circle only for ``|u| < ρ``).

**Poles** (``features="poles"``, tree-like objects, the Victoria Park kind). A segment is a pole when both its
neighbours lie behind it — each neighbour is a no-return, beyond ``max_range``, or farther by more than ``jump``
(a segment at the edge of the field of view is not) — and its diameter is in ``[min_diameter, max_diameter]``.
With the n beams spanning an extent ``nΔθ`` (each edge lies within half a beam step of the outermost hit beam),
the tangents from the sensor give the radius ``ρ = r_c sin(nΔθ/2)`` of a circle whose centre is at range
``r_c ≈ r_f + ρ``; so with ``s = sin(nΔθ/2)``: ``ρ = r_f s / (1 − s)``, diameter ``D = 2ρ``.

**Beacons** (``features="beacons"``, retro-reflective). A bright segment is a beacon when its chord
``w = r_f · nΔθ`` is at most ``max_beacon_width`` (a reflective strip on a car or a wall is wider); its centre
is a circle of radius ``ρ = beacon_radius``, ``D = 2ρ``.

**Covariance** (diagonal, per detection, range-dependent). The edges of the extent are quantised to the beam step:
each is uniform over one step, variance Δθ²/12, so the centre of two edges has variance Δθ²/24 (a single-beam
segment: its centre is uniform over the step, Δθ²/12). With the sensor's range noise ``sigma_range`` and a
beam-direction noise ``sigma_bearing``::

    σ_β² = Δθ²/24 (n ≥ 2) or Δθ²/12 (n = 1)  +  sigma_bearing²
    σ_r² = sigma_range² / m  +  (poles) r² Δθ²/24          (ρ ≈ r · extent/2, the half-extent's variance Δθ²/24)

**Robot frame** (:func:`to_robot_frame`). The sensor sits at ``mount = (a, b, θ_m)`` in the robot frame: the point
``p = (a, b) + R(θ_m) r (cos β, sin β)`` has range ``|p|`` and bearing ``atan2(p_y, p_x)``; the covariance maps
through ``J = J_polar(p) R(θ_m) J_cart(r, β)`` as ``J Σ Jᵀ`` (2, 2).

research/method/landmark_extraction.md states what this detects and what it does not.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from pydantic import ConfigDict, model_validator

from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sequence import Noise, RangeBearing, Scans, Sequence
from slamarena.params import Field, Params, with_params

__all__ = ["ExtractionParams", "Detections", "extract", "to_robot_frame", "landmark_sequence"]


class ExtractionParams(Params):
    """Parameters of :func:`extract` (metres, radians; the model is in the module docstring)."""

    model_config = ConfigDict(allow_inf_nan=False)

    features: Literal["beacons", "poles"] = Field(
        "beacons",
        description="'beacons': bright (retro-reflective) segments; 'poles': narrow segments in front of both neighbours",
    )
    min_range: float = Field(0.5, ge=0, description="readings nearer than this are not used [m]")
    max_range: float = Field(30.0, gt=0, description="readings beyond this are background, not features [m]")
    jump: float = Field(0.5, gt=0, description="a range step between neighbouring beams that splits a segment [m]")
    intensity_min: float = Field(
        0.5, description="a beam is bright at this intensity or above (beacons; the sensor's own intensity units)"
    )
    max_beacon_width: float = Field(0.5, gt=0, description="the widest chord of a beacon's bright segment [m]")
    bridge: int = Field(
        2, ge=0, description="bright runs split by at most this many beams (ranges within jump) are one beacon"
    )
    beacon_radius: float = Field(
        0.0, ge=0, description="radius of a beacon: its centre lies this far behind the return [m]"
    )
    min_beams: int = Field(1, ge=1, description="the fewest beams of a feature")
    min_diameter: float = Field(0.05, ge=0, description="smallest pole diameter [m]")
    max_diameter: float = Field(1.0, gt=0, description="largest pole diameter [m]")
    sigma_range: float = Field(0.03, gt=0, description="std of one range reading [m] (the sensor's)")
    sigma_bearing: float = Field(0.001, ge=0, description="std of a beam's direction [rad] (the sensor's)")

    @model_validator(mode="after")
    def _ranges_ordered(self):
        if self.min_range >= self.max_range:
            raise ValueError(f"min_range ({self.min_range}) must be below max_range ({self.max_range})")
        if self.min_diameter >= self.max_diameter:
            raise ValueError(f"min_diameter ({self.min_diameter}) must be below max_diameter ({self.max_diameter})")
        return self


@dataclass(frozen=True)
class Detections:
    """Features found in scans, in the sensor frame: scan index and stamp, range and bearing of the feature's centre,
    diameter [m], beams, and the covariance of (range, bearing) (M, 2, 2)."""

    scan: np.ndarray
    t: np.ndarray
    range: np.ndarray
    bearing: np.ndarray
    cov: np.ndarray
    diameter: np.ndarray
    beams: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


def _segments(valid: np.ndarray, ranges: np.ndarray, jump: float) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices (into the (S, B) arrays) of the first and last beam of every run of ``valid`` beams without a
    range step above ``jump`` and without crossing a scan's end."""
    S, B = valid.shape
    step = np.abs(np.diff(ranges, axis=1)) > jump  # (S, B − 1): a break between beams i and i + 1
    joined = valid[:, :-1] & valid[:, 1:] & ~step
    start = valid.copy()
    start[:, 1:] &= ~joined
    end = valid.copy()
    end[:, :-1] &= ~joined
    return np.flatnonzero(start), np.flatnonzero(end)


def _bridged(first, last, flat, B, bridge, jump):
    """Runs of bright beams joined across gaps of at most ``bridge`` beams within a scan when the ranges on either side
    of the gap differ by at most ``jump`` (a beacon whose reflection drops out on a beam or two); the joined runs'
    first and last flat indices and which of them were joined."""
    gap = first[1:] - last[:-1] - 1
    join = (first[1:] // B == last[:-1] // B) & (gap <= bridge) & (np.abs(flat[first[1:]] - flat[last[:-1]]) <= jump)
    starts, ends = np.r_[True, ~join], np.r_[~join, True]
    group = np.cumsum(starts) - 1
    merged = np.bincount(group, minlength=int(starts.sum())) > 1
    return first[starts], last[ends], merged


@with_params(ExtractionParams)
def extract(scans: Scans, /, *, params: ExtractionParams) -> Detections:
    """Beacons or poles in every scan (see the module docstring), in the sensor frame, ordered by scan and bearing."""
    p = params
    if scans.angle_offset is not None or scans.beam_count is not None:
        raise ValueError("extract: interlaced scans (angle_offset, beam_count) are not supported")
    angles = scans.angles
    steps = np.diff(angles)
    if angles.size < 2 or not np.allclose(steps, steps[0], rtol=1e-6, atol=1e-9) or steps[0] <= 0:
        raise ValueError("extract: the beam angles must be increasing at a uniform step")
    dtheta = float(steps[0])
    r = scans.ranges.astype(np.float64)
    S, B = r.shape
    with np.errstate(invalid="ignore"):
        returned = np.isfinite(r) & (r < scans.max_range)
        valid = returned & (r >= p.min_range) & (r <= p.max_range)
    if p.features == "beacons":
        if scans.intensities is None:
            raise ValueError("extract: beacons need intensities (Scans.intensities is None)")
        member = valid & (scans.intensities >= p.intensity_min)
    else:
        member = valid
    first, last = _segments(member, np.where(member, r, 0.0), p.jump)
    flat = r.ravel()
    merged = np.zeros(first.shape, dtype=bool)
    if p.features == "beacons" and p.bridge > 0 and first.size > 1:
        first, last, merged = _bridged(first, last, flat, B, p.bridge, p.jump)
    n = last - first + 1
    mid_lo, mid_hi = (first + last) // 2, (first + last + 1) // 2
    r_mid = np.stack([flat[mid_lo], flat[mid_hi]])
    m = np.where(mid_lo == mid_hi, 1, 2)
    if merged.any():  # a bridged beacon: its middle beam may be a gap's; the mean of its bright beams instead
        bright = np.cumsum(np.where(member.ravel(), flat, 0.0)), np.cumsum(member.ravel())
        total = [c[last] - np.where(first > 0, c[first - 1], 0) for c in bright]
        r_mid[:, merged] = (total[0] / total[1])[merged]
        m = np.where(merged, total[1], m)
    r_front = r_mid.mean(axis=0)
    beam_first = first % B
    bearing = angles[beam_first] + 0.5 * (n - 1) * dtheta
    extent = n * dtheta
    keep = n >= p.min_beams
    if p.features == "beacons":
        radius = np.full(n.shape, p.beacon_radius)
        keep &= r_front * extent <= p.max_beacon_width
    else:
        # both neighbours behind the segment: no return, beyond max_range, or farther by more than jump
        background = ~returned | (r > p.max_range)
        before, after = first - 1, last + 1
        inner_before = (first % B) > 0
        inner_after = (last % B) < B - 1
        flat_bg = background.ravel()

        def behind(k, inner):
            k = np.clip(k, 0, flat.size - 1)
            return inner & (flat_bg[k] | (flat[k] - r_front > p.jump))

        keep &= behind(before, inner_before) & behind(after, inner_after)
        s = np.sin(0.5 * np.minimum(extent, 3.0))
        radius = r_front * s / (1.0 - s)
        keep &= (2 * radius >= p.min_diameter) & (2 * radius <= p.max_diameter)
    # the centre's range from the middle beam(s): beam i at δ_i from the centre bearing hits the circle at r_i, so
    # (r_i cos δ_i − r_c)² + (r_i sin δ_i)² = ρ², r_c = r_i cos δ_i + √(ρ² − r_i² sin² δ_i) (the root clamped at 0)
    centre = np.zeros(n.shape)
    for k, r_k in zip((mid_lo, mid_hi), r_mid):
        delta = np.where(merged, 0.0, angles[k % B] - bearing)
        centre += r_k * np.cos(delta) + np.sqrt(np.maximum(radius**2 - (r_k * np.sin(delta)) ** 2, 0.0))
    # the centre bearing's quantisation error e_β (variance v_β below) puts the middle beam off the circle's apex by
    # u = r e_β, where the surface lies u²/(2ρ) deeper: the formula's mean bias E[u²]/(2ρ) is removed, E[u²] = r² v_β
    # but at most ρ²/3 (a beam meets the circle only for |u| < ρ: u is then uniform over (−ρ, ρ))
    v_quant = np.where(n >= 2, dtheta**2 / 24.0, dtheta**2 / 12.0)
    rng = 0.5 * centre
    rng -= np.minimum(rng**2 * v_quant, radius**2 / 3.0) / (2.0 * np.maximum(radius, 1e-9))
    var_b = v_quant + p.sigma_bearing**2
    var_r = p.sigma_range**2 / m + (rng**2 * dtheta**2 / 24.0 if p.features == "poles" else 0.0)
    cov = np.zeros((n.size, 2, 2))
    cov[:, 0, 0], cov[:, 1, 1] = var_r, var_b
    scan = first // B
    return Detections(
        scan=scan[keep],
        t=scans.t[scan[keep]],
        range=rng[keep],
        bearing=wrap_angle(bearing[keep]),
        cov=cov[keep],
        diameter=2 * radius[keep],
        beams=n[keep],
    )


def to_robot_frame(
    rng: np.ndarray, bearing: np.ndarray, cov: np.ndarray, mount
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range, bearing (M,) and covariance (M, 2, 2) of sensor-frame observations seen from the robot frame's origin,
    the sensor at ``mount = (a, b, θ_m)`` (the module docstring)."""
    a, b, th = np.asarray(mount, dtype=float).reshape(3)
    rng, bearing = np.asarray(rng, dtype=float), np.asarray(bearing, dtype=float)
    ang = bearing + th
    c, s = np.cos(ang), np.sin(ang)
    px, py = a + rng * c, b + rng * s
    q = px**2 + py**2
    r2 = np.sqrt(q)
    # ∂(px, py)/∂(r, β) = R(θ_m) J_cart = [[c, −r s], [s, r c]]; ∂(r', β')/∂(px, py) = [[px/r', py/r'], [−py/q, px/q]]
    Jc = np.stack([np.stack([c, -rng * s], -1), np.stack([s, rng * c], -1)], -2)
    Jp = np.stack([np.stack([px / r2, py / r2], -1), np.stack([-py / q, px / q], -1)], -2)
    J = Jp @ Jc
    return r2, wrap_angle(np.arctan2(py, px)), J @ cov @ np.swapaxes(J, -1, -2)


def landmark_sequence(sequence: Sequence, params: ExtractionParams | None = None) -> Sequence:
    """``sequence`` with the landmarks its scans show as its range-bearing stream (robot frame, ids −1), the median
    per-observation covariance as ``Noise.range_bearing_cov`` and every observation's covariance in
    ``meta["range_bearing_cov_per_observation"]`` (M, 2, 2). Any range-bearing stream it had is replaced."""
    if sequence.scans is None:
        raise ValueError(f"{sequence.name}: no scans to extract landmarks from")
    params = params or ExtractionParams()
    det = extract(sequence.scans, params=params)
    rng, bearing, cov = to_robot_frame(det.range, det.bearing, det.cov, sequence.scans.mount)
    rb = RangeBearing(t=det.t, range=rng, bearing=bearing, landmark_id=np.full(len(det), -1))
    R = np.median(cov, axis=0) if len(det) else None
    meta = {
        **sequence.meta,
        "range_bearing": f"extracted from the scans ({params.features}; mapping/landmark_extraction.py)",
        "extraction": params.canonical(),
        "extracted": len(det),
        "extracted_per_scan": len(det) / max(1, len(sequence.scans)),
        "range_bearing_cov_per_observation": cov,
    }
    return replace(
        sequence,
        range_bearing=rb,
        noise=replace(sequence.noise or Noise(), range_bearing_cov=R),
        meta=meta,
    )
