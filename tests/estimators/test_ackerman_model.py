"""The Ackerman vehicle model (estimators/models.py AckermanModel, datasets/kinematics.py ackerman_twist): its
Jacobians against central finite differences, and the sensor-point model against the rear axle's twist carried to the
sensor by a rigid transform."""

from __future__ import annotations

import numpy as np

from slamarena.datasets import kinematics
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.estimators.models import AckermanModel

#: the ACFR utility vehicle (acfr_carpark/SOURCE.md)
CAR = AckermanModel(wheelbase=2.83, encoder_offset=0.76, mount=(3.78, 0.50))


def test_twist_is_the_encoder_wheel_on_its_circle():
    speed, steering = np.array([2.0, 2.0, 1.5, 0.0]), np.array([0.0, 0.3, -0.5, 0.2])
    v, w = CAR.twist(speed, steering)
    assert v[0] == 2.0 and w[0] == 0.0 and v[3] == 0.0
    # turning radius R = L / tan α of the axle centre; the encoder wheel (h to the left) runs on R − h at the same ω
    R = CAR.wheelbase / np.tan(steering[1:3])
    assert np.allclose(w[1:3] * (R - CAR.encoder_offset), speed[1:3])
    assert np.allclose(kinematics.ackerman_twist(speed, steering, 2.83, 0.0)[0], speed)


def _fd(f, x0, eps=1e-6):
    """Central differences of f (…, m) at x0 (n,) → (m, n), angle rows wrapped."""
    cols = []
    for i in range(len(x0)):
        d = np.zeros(len(x0))
        d[i] = eps
        diff = f(x0 + d) - f(x0 - d)
        if diff.shape[-1] == 3:
            diff[..., 2] = wrap_angle(diff[..., 2])
        cols.append(diff / (2 * eps))
    return np.stack(cols, axis=-1)


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = np.array([*rng.uniform(-20, 20, 2), rng.uniform(-np.pi, np.pi)])
        u = np.array([rng.uniform(0, 3), rng.uniform(-0.6, 0.6)])
        dt = 0.025
        J = CAR.twist_jacobian(*u)
        assert np.allclose(J, _fd(lambda q: np.array(CAR.twist(*q)), u), atol=1e-7)
        G, V = CAR.jacobians(x, *u, dt)
        assert np.allclose(G, _fd(lambda q: CAR.predict(q, *u, dt), x), atol=1e-8)
        assert np.allclose(V, _fd(lambda q: CAR.predict(x, q[0], q[1], dt), u), atol=1e-8)
    # broadcasting: a batch of states and inputs gives the stacked Jacobians
    xs, us = rng.uniform(-1, 1, (5, 3)), np.column_stack([rng.uniform(0, 3, 5), rng.uniform(-0.5, 0.5, 5)])
    G, V = CAR.jacobians(xs, us[:, 0], us[:, 1], 0.025)
    assert G.shape == (5, 3, 3) and V.shape == (5, 3, 2)
    assert np.allclose(V[2], CAR.jacobians(xs[2], *us[2], 0.025)[1])


def test_sensor_point_moves_with_the_axle_twist():
    """Guivant's sensor-point equations are the rigid-body motion of the point (a, b): integrating them at a fine step
    reaches the sensor pose of the axle driven by its twist (exact arc steps) within the Euler error."""
    t = np.arange(0, 10, 0.001)
    speed, steering = 1.5 + 0.5 * np.sin(0.7 * t), 0.4 * np.sin(0.5 * t)
    v, w = CAR.twist(speed, steering)
    axle = kinematics.integrate("arc", np.zeros(3), v, w, 0.001)
    mount = np.array([*CAR.mount, 0.0])
    sensor = np.empty((t.size + 1, 3))
    sensor[0] = compose(np.zeros(3), mount)
    for k in range(t.size):
        sensor[k + 1] = CAR.predict(sensor[k], speed[k], steering[k], 0.001)
    expected = compose(axle, mount)
    assert np.max(np.hypot(*(sensor[:, :2] - expected[:, :2]).T)) < 0.02  # 16 m of driving
    assert np.max(np.abs(wrap_angle(sensor[:, 2] - expected[:, 2]))) < 1e-3
