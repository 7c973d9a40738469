"""SE(2) geometry used everywhere in slamarena: one implementation, vectorised.

Poses are arrays ``[..., 3]`` holding ``(x, y, theta)``: the pose of a body frame in a
reference frame, metres and radians, counter-clockwise positive. Every function accepts
single poses ``(3,)`` or stacks ``(K, 3)`` and broadcasts like numpy.

    compose(a, b)  = a ⊕ b      : pose b (given in frame a) expressed in a's reference frame
    inverse(a)     = ⊖a
    between(a, b)  = ⊖a ⊕ b     : pose b seen from a (what g2o's EDGE_SE2 stores)
    transform_points(a, p)      : points p (given in frame a) expressed in a's reference frame
    range_bearing(a, p)         : range and bearing of world points p seen from pose a

Angles are wrapped to (−π, π] by :func:`wrap_angle`, the project's one convention; :func:`wrap_scalar` is the same
formula for one float, which compiled kernels compile (``numba.njit(wrap_scalar)``), so compiled and numpy code agree
bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "wrap_angle",
    "wrap_scalar",
    "compose",
    "inverse",
    "between",
    "transform_points",
    "range_bearing",
    "rotation",
    "interpolate_poses",
    "accumulate",
    "se2_log",
    "se2_exp",
]


def wrap_angle(angle: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles to the half-open interval (−π, π]: π − ((π − a) mod 2π), and π where that rounds to −π (just above
    π + 2πk, where (π − a) mod 2π rounds up to 2π)."""
    a = np.asarray(angle, dtype=float)
    wrapped = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    if np.ndim(wrapped) == 0:
        return math.pi if wrapped == -math.pi else float(wrapped)
    np.copyto(wrapped, np.pi, where=wrapped == -np.pi)
    return wrapped


def wrap_scalar(a: float) -> float:
    """One angle wrapped to (−π, π], :func:`wrap_angle` on a float (Python's ``%`` is numpy's ``mod``, bit for bit);
    compiled kernels use ``numba.njit(wrap_scalar)``."""
    w = math.pi - (math.pi - a) % (2.0 * math.pi)
    return math.pi if w == -math.pi else w


def rotation(theta: np.ndarray | float) -> np.ndarray:
    """Rotation matrices R(theta), shape ``theta.shape + (2, 2)``."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


def _pose(x, y, th) -> np.ndarray:
    """The components stacked into poses ``(..., 3)`` (one pose: without numpy's broadcasting machinery, the hot case)."""
    if np.ndim(x) == 0 and np.ndim(y) == 0 and np.ndim(th) == 0:
        return np.array([x, y, th], dtype=float)
    return np.stack(np.broadcast_arrays(x, y, th), axis=-1)


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a ⊕ b: the pose b, expressed in frame a, moved to a's reference frame."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    th = wrap_angle(a[..., 2] + b[..., 2])
    return _pose(x, y, th)


def inverse(a: np.ndarray) -> np.ndarray:
    """⊖a: the reference frame seen from pose a."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    th = wrap_angle(-a[..., 2])
    return _pose(x, y, th)


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """⊖a ⊕ b: pose b expressed in the frame of pose a."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx = b[..., 0] - a[..., 0]
    dy = b[..., 1] - a[..., 1]
    x = c * dx + s * dy
    y = -s * dx + c * dy
    th = wrap_angle(b[..., 2] - a[..., 2])
    return _pose(x, y, th)


def transform_points(a: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points ``(..., 2)`` given in frame a, expressed in a's reference frame.

    ``a`` is one pose ``(3,)`` applied to every point, or a stack of poses broadcast
    against the leading dimensions of ``points``.
    """
    a = np.asarray(a, dtype=float)
    p = np.asarray(points, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    if a.ndim == 1:
        return np.stack([a[0] + c * p[..., 0] - s * p[..., 1], a[1] + s * p[..., 0] + c * p[..., 1]], axis=-1)
    c, s, ax, ay = (v[..., None] if p.ndim > a.ndim else v for v in (c, s, a[..., 0], a[..., 1]))
    return np.stack([ax + c * p[..., 0] - s * p[..., 1], ay + s * p[..., 0] + c * p[..., 1]], axis=-1)


def range_bearing(a: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range and bearing (wrapped, relative to the heading) of world points seen from pose a."""
    a = np.asarray(a, dtype=float)
    p = np.asarray(points, dtype=float)
    dx = p[..., 0] - a[..., 0]
    dy = p[..., 1] - a[..., 1]
    return np.hypot(dx, dy), wrap_angle(np.arctan2(dy, dx) - a[..., 2])


def accumulate(start: np.ndarray, deltas: np.ndarray) -> np.ndarray:
    """Prefix compositions ``start ⊕ d_0 ⊕ d_1 ⊕ …`` of body-frame increments, vectorised.

    Returns (K + 1, 3): the start pose followed by the pose after each increment. Headings
    are cumulative sums; each translation is rotated by the heading before its increment.
    """
    start = np.asarray(start, dtype=float).reshape(3)
    d = np.asarray(deltas, dtype=float).reshape(-1, 3)
    heading = start[2] + np.concatenate([[0.0], np.cumsum(d[:, 2])])
    c, s = np.cos(heading[:-1]), np.sin(heading[:-1])
    steps = np.column_stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]])
    xy = start[:2] + np.vstack([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    return np.column_stack([xy, wrap_angle(heading)])


def interpolate_poses(t_known: np.ndarray, poses: np.ndarray, t_query: np.ndarray) -> np.ndarray:
    """SE(2) interpolation of a time-stamped trajectory at query times.

    Between two known poses the motion is the constant-twist (geodesic) path of SE(2):
    the relative pose ``d = between(p0, p1)`` is scaled in its Lie algebra by the time
    fraction. Query times outside ``[t_known[0], t_known[-1]]`` are an error.
    """
    t_known = np.asarray(t_known, dtype=float)
    poses = np.asarray(poses, dtype=float)
    t_query = np.asarray(t_query, dtype=float)
    if t_query.size and (t_query.min() < t_known[0] or t_query.max() > t_known[-1]):
        raise ValueError("interpolate_poses: query times outside the known time range")
    k = np.clip(np.searchsorted(t_known, t_query, side="right") - 1, 0, len(t_known) - 2)
    span = t_known[k + 1] - t_known[k]
    frac = np.divide(t_query - t_known[k], span, out=np.zeros_like(t_query), where=span > 0)
    d = between(poses[k], poses[k + 1])
    return compose(poses[k], _exp(frac[:, None] * _log(d)))


def _log(d: np.ndarray) -> np.ndarray:
    """SE(2) logarithm: relative pose → twist (vx, vy, w) integrated over unit time."""
    th = d[..., 2]
    small = np.abs(th) < 1e-9
    half = 0.5 * th
    # V^{-1} for SE(2): [[a, b], [-b, a]] with a = (θ/2) cot(θ/2), b = θ/2
    a = np.where(small, 1.0 - th**2 / 12.0, half / np.tan(np.where(small, 1.0, half)))
    vx = a * d[..., 0] + half * d[..., 1]
    vy = -half * d[..., 0] + a * d[..., 1]
    return np.stack([vx, vy, th], axis=-1)


def _exp(xi: np.ndarray) -> np.ndarray:
    """SE(2) exponential: twist (vx, vy, w) → relative pose."""
    th = xi[..., 2]
    small = np.abs(th) < 1e-9
    ths = np.where(small, 1.0, th)
    s = np.where(small, 1.0 - th**2 / 6.0, np.sin(ths) / ths)
    c = np.where(small, 0.5 * th, (1.0 - np.cos(ths)) / ths)
    x = s * xi[..., 0] - c * xi[..., 1]
    y = c * xi[..., 0] + s * xi[..., 1]
    return np.stack([x, y, wrap_angle(th)], axis=-1)


#: public names of the SE(2) logarithm / exponential (relative pose ↔ twist over unit time)
se2_log = _log
se2_exp = _exp
