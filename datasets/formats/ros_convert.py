"""ROS messages → the arrays of the data model (REP 103 frames: x forward, y left, z up; ENU in the world).

* Orientation: a quaternion ``(x, y, z, w)`` → yaw ``atan2(2(wz + xy), 1 − 2(y² + z²))`` (the rotation about z
  of a planar robot; roll and pitch are ignored, and must be small for a 2D method to apply).
* ``sensor_msgs/LaserScan`` (REP 117): beam b points at ``angle_min + b·angle_increment``; a reading is
  *no return* when it is +inf or ≥ ``range_max`` (kept as ``range_max``'s sentinel: readings ≥ max_range are
  "no return" in :class:`~slamarena.datasets.sequence.Scans`), *invalid* when it is NaN, −inf or below
  ``range_min`` (stored as NaN: consumers reject and count it).
* ``tf2_msgs/TFMessage``: the laser's mounting is the chain of transforms from the base frame to the laser's frame
  (each ``parent → child``, static ones from ``/tf_static``, a moving link's first transform from ``/tf``),
  composed in 3D; it must be a rotation about z (a level laser), then it is ``(x, y, yaw)``, or an upside-down laser
  (``R_z(ψ) R_x(π)``): ``(x, y, ψ)`` with the beam angles negated (:func:`planar_mount`).
* ``sensor_msgs/NavSatFix`` → a local east-north frame: WGS-84 geodetic (φ, λ, h) → ECEF → ENU at the origin
  (φ₀, λ₀, h₀) (the first valid fix unless given): ``e = −sin λ₀ Δx + cos λ₀ Δy``,
  ``n = −sin φ₀ cos λ₀ Δx − sin φ₀ sin λ₀ Δy + cos φ₀ Δz`` with ``Δ = ECEF(φ, λ, h) − ECEF(φ₀, λ₀, h₀)``
  (exact, no small-area approximation). Fixes with ``status < 0`` (no fix) or non-finite values are dropped.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "yaw_of",
    "scan_arrays",
    "layout_of",
    "planar_mount",
    "mount_from_tf",
    "enu_of",
    "ecef_of",
    "WGS84_A",
    "WGS84_F",
]

WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563


def yaw_of(q: np.ndarray) -> np.ndarray:
    """Yaw of quaternions ``(..., 4)`` ordered ``(x, y, z, w)``."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def scan_arrays(messages: list) -> dict:
    """The ranges (S, B) float32, intensities (S, B) or None, angles (B,), range_min, range_max and the count of
    readings of each kind of the LaserScan ``messages`` (one beam layout; callers check :func:`layout_of`)."""
    first = messages[0]
    B = len(first.ranges)
    ranges = np.stack([np.asarray(m.ranges, dtype=np.float32) for m in messages])
    rmin = np.array([m.range_min for m in messages], dtype=np.float32)[:, None]
    rmax = np.array([m.range_max for m in messages], dtype=np.float32)[:, None]
    no_return = np.isposinf(ranges) | (ranges > rmax)
    invalid = np.isnan(ranges) | np.isneginf(ranges) | (ranges < rmin)
    ranges = np.where(no_return, np.broadcast_to(rmax, ranges.shape), ranges)
    ranges = np.where(invalid, np.float32(np.nan), ranges).astype(np.float32)
    has_intensity = all(len(m.intensities) == B for m in messages) and B > 0
    intensities = np.stack([np.asarray(m.intensities, dtype=np.float32) for m in messages]) if has_intensity else None
    angles = float(first.angle_min) + float(first.angle_increment) * np.arange(B)
    return {
        "ranges": ranges,
        "intensities": intensities,
        "angles": angles,
        "range_min": float(rmin.min()),
        "range_max": float(rmax.max()),
        "no_return_readings": int(no_return.sum()),
        "invalid_readings": int(invalid.sum()),
    }


def layout_of(m) -> tuple[int, float, float]:
    """The beam layout ``(beams, angle_min, angle_increment)`` of a LaserScan (angles rounded to 1e-9 rad)."""
    return len(m.ranges), round(float(m.angle_min), 9), round(float(m.angle_increment), 12)


def planar_mount(pose: np.ndarray) -> tuple[np.ndarray, bool] | None:
    """``(x, y, ψ)`` of a 4 × 4 laser pose in the base frame and whether the laser is upside down, or None when it is
    not level. Level: ``R = R_z(ψ)`` (|R₂₂ − 1| ≤ 1e-6). Upside down: ``R = R_z(ψ) R_x(π)`` (|R₂₂ + 1| ≤ 1e-6; a beam
    at angle a in the laser frame points at ψ − a in the base frame, so the caller negates the beam angles). Either
    way ψ = atan2(R₁₀, R₀₀) (R_x(π) keeps the x axis)."""
    if abs(abs(pose[2, 2]) - 1.0) > 1e-6:
        return None
    return np.array([pose[0, 3], pose[1, 3], np.arctan2(pose[1, 0], pose[0, 0])]), bool(pose[2, 2] < 0)


def _transform_matrix(transform) -> np.ndarray:
    t, q = transform.translation, transform.rotation
    out = np.eye(4)
    out[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    out[:3, 3] = [t.x, t.y, t.z]
    return out


def mount_from_tf(tf_messages: list, base: str, laser: str) -> tuple[np.ndarray, list[str]] | None:
    """The pose (4, 4) of frame ``laser`` in frame ``base`` and the frames of the chain, from the TFMessages
    ``tf_messages`` (static first, then dynamic; the first transform of each child wins); None without a chain."""
    parent_of: dict[str, tuple[str, np.ndarray]] = {}
    for message in tf_messages:
        for ts in message.transforms:
            child = ts.child_frame_id.lstrip("/")
            if child not in parent_of:
                parent_of[child] = (ts.header.frame_id.lstrip("/"), _transform_matrix(ts.transform))
    base, laser = base.lstrip("/"), laser.lstrip("/")

    def to_root(frame: str) -> list[str]:
        chain = [frame]
        while chain[-1] in parent_of and len(chain) <= len(parent_of):
            chain.append(parent_of[chain[-1]][0])
        return chain

    up_laser, up_base = to_root(laser), to_root(base)
    common = next((f for f in up_laser if f in up_base), None)
    if common is None:
        return None

    def pose_in(chain: list[str]) -> np.ndarray:  # pose of chain[0] in the common ancestor
        out = np.eye(4)
        for frame in chain[: chain.index(common)]:
            out = parent_of[frame][1] @ out
        return out

    pose = np.linalg.inv(pose_in(up_base)) @ pose_in(up_laser)
    frames = up_base[: up_base.index(common) + 1] + up_laser[: up_laser.index(common)][::-1]
    return pose, frames


def ecef_of(lat_deg: np.ndarray, lon_deg: np.ndarray, alt: np.ndarray) -> np.ndarray:
    """WGS-84 geodetic (degrees, metres above the ellipsoid) → ECEF (N, 3) [m]."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    e2 = WGS84_F * (2.0 - WGS84_F)
    N = WGS84_A / np.sqrt(1.0 - e2 * np.sin(phi) ** 2)
    return np.column_stack(
        [
            (N + alt) * np.cos(phi) * np.cos(lam),
            (N + alt) * np.cos(phi) * np.sin(lam),
            (N * (1.0 - e2) + alt) * np.sin(phi),
        ]
    )


def enu_of(lat_deg, lon_deg, alt, origin: tuple[float, float, float]) -> np.ndarray:
    """East, north, up (N, 3) [m] of geodetic points relative to ``origin`` (lat°, lon°, alt m) (module docstring)."""
    lat0, lon0, alt0 = origin
    d = ecef_of(np.atleast_1d(lat_deg), np.atleast_1d(lon_deg), np.atleast_1d(alt)) - ecef_of(
        np.array([lat0]), np.array([lon0]), np.array([alt0])
    )
    phi, lam = np.radians(lat0), np.radians(lon0)
    R = np.array(
        [
            [-np.sin(lam), np.cos(lam), 0.0],
            [-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)],
            [np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)],
        ]
    )
    return d @ R.T
