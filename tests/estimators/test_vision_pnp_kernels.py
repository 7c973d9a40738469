"""The compiled PnP kernels (``estimators/vision/pnp.py``) against their literal numpy forms and OpenCV.

The literal forms below are the vectorised versions the kernels replaced (P3P by ``np.roots`` and ``np.convolve``,
LM with the Jacobians of :mod:`~slamarena.estimators.vision.projection` and :func:`~.lie.se3_exp`): the kernels must
return the same numbers."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from slamarena.estimators.vision import pnp
from slamarena.estimators.vision.lie import rotation_angle, se3_exp, se3_exp_kernel, so3_exp
from slamarena.estimators.vision.projection import jacobians, normalise, project, residuals
from slamarena.estimators.vision.ransac import iterations_needed

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])


def literal_absolute_orientation(X, Y):
    mx, my = X.mean(axis=0), Y.mean(axis=0)
    U, _, Vt = np.linalg.svd((Y - my).T @ (X - mx))
    R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0]) @ Vt
    return R, my - R @ mx


def literal_p3p(X, x):
    f = np.column_stack([x, np.ones(3)])
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    a2, b2, c2 = np.sum((X[1] - X[2]) ** 2), np.sum((X[0] - X[2]) ** 2), np.sum((X[0] - X[1]) ** 2)
    ca, cb, cg = f[1] @ f[2], f[0] @ f[2], f[0] @ f[1]
    w = np.array([1.0, -2.0 * cb, 1.0])
    p2, p1, p0 = np.array([b2, 0.0, 0.0]), np.array([0.0, -2.0 * b2 * ca, 0.0]), np.array([0.0, 0.0, b2]) - a2 * w
    q2, q1, q0 = np.array([b2, 0.0, 0.0]), np.array([-2.0 * b2 * cg, 0.0, 0.0]), np.array([b2, 0.0, 0.0]) - c2 * w
    d20, d21 = np.convolve(p2, q0) - np.convolve(p0, q2), np.convolve(p2, q1) - np.convolve(p1, q2)
    d10 = np.convolve(p1, q0) - np.convolve(p0, q1)
    roots = np.roots((np.convolve(d20, d20) - np.convolve(d21, d10))[:5][::-1])
    out = []
    for v in roots[np.abs(roots.imag) <= 1e-6 * np.maximum(1.0, np.abs(roots.real))].real:
        powers = np.array([1.0, v, v * v])
        u = (q0 - p0) @ powers / ((p1 - q1) @ powers)
        s1_squared = b2 / (w @ powers)
        if v > 0 and u > 0 and s1_squared > 0:
            s1 = np.sqrt(s1_squared)
            out.append(literal_absolute_orientation(X, np.array([s1, u * s1, v * s1])[:, None] * f))
    return out


def literal_refine(K, R, t, X, u, iterations=20, tolerance=1e-10):
    def cost(R, t):
        return np.inf if np.any(X @ R[2] + t[2] <= 0) else float(np.sum(residuals(K, R, t, X, u) ** 2))

    current, lam = cost(R, t), 1e-3
    for _ in range(iterations):
        r, J = residuals(K, R, t, X, u).reshape(-1), jacobians(K, R, t, X)[0].reshape(-1, 6)
        H = J.T @ J
        step = np.linalg.solve(H + lam * np.diag(np.diag(H)), -J.T @ r)
        dR, dt = se3_exp(step)
        new = cost(dR @ R, dR @ t + dt)
        if new < current:
            decrease = current - new
            R, t, current, lam = dR @ R, dR @ t + dt, new, lam / 10
            if decrease <= tolerance * max(current, 1e-300) or np.linalg.norm(step) < 1e-12:
                break
        else:
            lam *= 10
            if lam > 1e8:
                break
    return R, t, float(np.sqrt(current / len(X)))


def test_p3p_kernel_equals_the_literal_form(rng):
    for _ in range(200):
        R, t = so3_exp(rng.normal(size=3)), rng.normal(size=3)
        Xc = rng.uniform([-3, -3, 2], [3, 3, 8], size=(3, 3))
        X, x = (Xc - t) @ R, Xc[:, :2] / Xc[:, 2:]
        ours, literal = pnp.p3p(X, x), literal_p3p(X, x)
        assert len(ours) == len(literal)
        for Ro, to in ours:  # the same set (complex vs real eigenvalue routines: to 1e-5 near a double root)
            assert min(np.abs(Ro - Rl).max() + np.abs(to - tl).max() for Rl, tl in literal) < 1e-5


def test_absolute_orientation_kernel_equals_the_literal_form(rng):
    for _ in range(20):
        X = rng.normal(size=(10, 3))
        Y = X @ so3_exp(rng.normal(size=3)).T + rng.normal(size=3) + rng.normal(size=(10, 3)) * 0.1
        for a, b in zip(pnp.absolute_orientation(X, Y), literal_absolute_orientation(X, Y)):
            np.testing.assert_allclose(a, b, atol=1e-12)


def test_se3_exp_kernel_equals_the_vectorised_map(rng):
    for xi in [*rng.normal(size=(20, 6)), np.array([0.1, 0, 0, 1e-6, 0, 0]), np.array([0, 0, 1, 0, 3.1, 0])]:
        for a, b in zip(se3_exp_kernel(xi), se3_exp(xi)):
            np.testing.assert_allclose(a, b, atol=1e-12)


def test_refine_kernel_equals_the_literal_levenberg_marquardt(rng):
    for _ in range(10):
        R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
        X = (rng.uniform([-3, -2, 4], [3, 2, 30], size=(60, 3)) - t) @ R
        u = project(K, R, t, X) + rng.normal(size=(60, 2))
        R0, t0 = so3_exp(rng.normal(size=3) * 0.02) @ R, t + rng.normal(size=3) * 0.05
        for a, b in zip(pnp.refine_pose(K, R0, t0, X, u), literal_refine(K, R0, t0, X, u)):
            np.testing.assert_allclose(a, b, atol=1e-9)


def test_epnp_kernel_is_within_a_fraction_of_its_own_error_of_opencvs_epnp(rng):
    """Lepetit's three linearisations and Gauss-Newton, as OpenCV's EPnP: with 1 px noise the two poses differ by a
    small fraction of either's error (not bit-equal: control-point order and the final choice differ)."""
    gap, error = [], []
    for _ in range(60):
        R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
        X = (rng.uniform([-3, -2, 4], [3, 2, 20], size=(20, 3)) - t) @ R
        u = project(K, R, t, X) + rng.normal(size=(20, 2))
        Re, _ = pnp.epnp(X, normalise(K, u))
        _, rv, _ = cv2.solvePnP(X, u, K, None, flags=cv2.SOLVEPNP_EPNP)
        gap.append(rotation_angle(Re.T @ cv2.Rodrigues(rv)[0]))
        error.append(rotation_angle(Re.T @ R))
    assert np.median(gap) < 0.3 * np.median(error)


def test_ransac_kernel_counts_and_stops_as_the_literal_rules_say(rng):
    R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
    X = (rng.uniform([-3, -2, 4], [3, 2, 30], size=(200, 3)) - t) @ R
    u = project(K, R, t, X) + rng.normal(size=(200, 2)) * 0.5
    u[:60] += rng.uniform(-80, 80, size=(60, 2))
    for minimal, size in (("p3p", 3), ("epnp", 6)):
        Rb, tb, count, drawn = pnp._ransac_kernel(K, X, normalise(K, u), u, minimal == "p3p", 2.0, 0.999, 1000, 7)
        literal = pnp._inliers(K, Rb, tb, X, u, 2.0)  # vectorised residuals
        assert count == literal.sum() == pnp._count_inliers(K, Rb, tb, X, u, 4.0)
        assert count >= 120 and iterations_needed(count / 200, size, 0.999, 1000) <= drawn <= 1000  # stopped at N(w)


@pytest.mark.parametrize("confidence, iterations", [(0.999, 1000), (0.99, 50)])
def test_iterations_needed_compiled_is_the_formula(confidence, iterations):
    for w in (0.1, 0.5, 0.9):
        expected = min(iterations, max(1, int(np.ceil(np.log(1 - confidence) / np.log(1 - w**3)))))
        assert iterations_needed(w, 3, confidence, iterations) == expected
