"""slamarena.datasets.geometry — SE(2) group laws and conventions, as hypothesis property tests."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from slamarena.datasets.geometry import (
    accumulate,
    between,
    compose,
    interpolate_poses,
    inverse,
    range_bearing,
    rotation,
    transform_points,
    wrap_angle,
)

coord = st.floats(-100.0, 100.0, allow_nan=False)
angle = st.floats(-20.0, 20.0, allow_nan=False)
pose = st.tuples(coord, coord, angle).map(np.array)
poses = st.integers(1, 8).flatmap(lambda n: st.lists(pose, min_size=n, max_size=n)).map(np.array)

#: per-test settings (a global profile would change every other module's property tests)
fast = settings(max_examples=60, deadline=None)


def assert_pose_close(a, b, atol=1e-8):
    a, b = np.asarray(a), np.asarray(b)
    np.testing.assert_allclose(a[..., :2], b[..., :2], atol=atol)
    np.testing.assert_allclose(wrap_angle(a[..., 2] - b[..., 2]), 0.0, atol=atol)


@fast
@given(arrays(np.float64, st.integers(1, 20), elements=st.floats(-1e3, 1e3)))
def test_wrap_is_idempotent_in_range_and_a_multiple_of_two_pi_away(a):
    w = wrap_angle(a)
    assert np.all((w > -math.pi) & (w <= math.pi))
    np.testing.assert_array_equal(wrap_angle(w), w)
    k = (a - w) / (2 * math.pi)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)


def test_wrap_boundaries():
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert wrap_angle(3 * math.pi) == pytest.approx(math.pi)
    assert wrap_angle(0.0) == 0.0
    assert isinstance(wrap_angle(1.0), float)


@fast
@given(pose)
def test_compose_with_inverse_is_identity(a):
    assert_pose_close(compose(a, inverse(a)), np.zeros(3))
    assert_pose_close(compose(inverse(a), a), np.zeros(3))
    assert_pose_close(inverse(inverse(a)), a)


@fast
@given(pose, pose)
def test_between_undoes_compose(a, d):
    assert_pose_close(between(a, compose(a, d)), d, atol=1e-7)
    assert_pose_close(compose(a, between(a, d)), d, atol=1e-7)
    assert_pose_close(between(a, d), compose(inverse(a), d), atol=1e-7)


@fast
@given(pose, pose, pose)
def test_compose_is_associative(a, b, c):
    assert_pose_close(compose(compose(a, b), c), compose(a, compose(b, c)), atol=1e-7)


@fast
@given(pose, st.floats(0.01, 50.0), st.floats(-math.pi, math.pi))
def test_transform_points_and_range_bearing_agree(a, r, b):
    local = np.array([r * math.cos(b), r * math.sin(b)])
    world = transform_points(a, local)
    rr, bb = range_bearing(a, world)
    assert rr == pytest.approx(r, rel=1e-9, abs=1e-9)
    assert abs(wrap_angle(bb - b)) < 1e-8
    # the same point as the translation of a composed pose
    np.testing.assert_allclose(compose(a, np.array([*local, 0.0]))[:2], world, atol=1e-9)
    np.testing.assert_allclose(world, a[:2] + rotation(a[2]) @ local, atol=1e-9)


@fast
@given(poses, st.integers(0, 7))
def test_vectorised_forms_equal_the_per_pose_forms(p, shift):
    q = np.roll(p, shift, axis=0)
    out = compose(p, q)
    for k in range(len(p)):
        np.testing.assert_array_equal(out[k], compose(p[k], q[k]))
        np.testing.assert_array_equal(between(p, q)[k], between(p[k], q[k]))
        np.testing.assert_array_equal(inverse(p)[k], inverse(p[k]))
    pts = p[:, :2] * 0.5
    stacked = transform_points(p, pts)  # pose k applied to point k
    for k in range(len(p)):
        np.testing.assert_allclose(stacked[k], transform_points(p[k], pts[k]), atol=1e-12)


@fast
@given(pose, poses)
def test_accumulate_is_repeated_compose(start, deltas):
    out = accumulate(start, deltas)
    assert out.shape == (len(deltas) + 1, 3)
    expected = np.asarray(start, dtype=float)
    assert_pose_close(out[0], expected)
    for k, d in enumerate(deltas):
        expected = compose(expected, d)
        assert_pose_close(out[k + 1], expected, atol=1e-6)


@fast
@given(pose, pose, st.floats(0.0, 10.0), st.floats(0.1, 5.0))
def test_interpolation_hits_the_endpoints(p0, p1, t0, span):
    t = np.array([t0, t0 + span])
    out = interpolate_poses(t, np.stack([p0, p1]), t)
    assert_pose_close(out[0], p0, atol=1e-7)
    assert_pose_close(out[1], p1, atol=1e-6)


@fast
@given(pose, st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(0.0, 1.0))
def test_interpolation_follows_a_constant_twist(p0, v, w, frac):
    """Along a constant-twist arc, every intermediate pose is the arc at that time (|ω T| < π)."""

    def arc(tau):
        if abs(w) < 1e-12:
            d = np.array([v * tau, 0.0, 0.0])
        else:
            d = np.array([v / w * math.sin(w * tau), v / w * (1 - math.cos(w * tau)), w * tau])
        return compose(p0, d)

    T = 1.0
    out = interpolate_poses(np.array([0.0, T]), np.stack([p0, arc(T)]), np.array([frac * T, 0.5 * T]))
    assert_pose_close(out[0], arc(frac * T), atol=1e-7)
    assert_pose_close(out[1], arc(0.5 * T), atol=1e-7)


def test_interpolation_outside_the_range_is_an_error():
    with pytest.raises(ValueError):
        interpolate_poses(np.array([0.0, 1.0]), np.zeros((2, 3)), np.array([1.5]))
