"""DLS PnP (``estimators/vision/dls.py``): exact on noise-free data (general, planar, rotations by π), every returned
stationary point a root of the three cubics, as accurate as OpenCV's SQPnP with noise, and inside the same RANSAC.

(OpenCV 5 has no ``SOLVEPNP_DLS`` any more — in 4.x it fell back to EPnP — so the oracle is SQPnP, the globally
optimal solver of the same object-space cost.)"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from slamarena.estimators.vision.dls import _C, _G, _cost_matrices, _monomial_values, _stationary_points, dls
from slamarena.estimators.vision.lie import rotation_angle, so3_exp
from slamarena.estimators.vision.pnp import pnp_ransac
from slamarena.estimators.vision.projection import normalise, project

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])


def view(rng, R, t, n=12, plane=False):
    Xc = rng.uniform([-3, -2, 4], [3, 2, 20], size=(n, 3))
    X = (Xc - t) @ R
    if plane:  # project onto the world plane Z = 0 in front of the camera
        X[:, 2] = 0.0
    return X, project(K, R, t, X)


@pytest.mark.parametrize("plane", [False, True])
def test_dls_is_exact_without_noise(rng, plane):
    for _ in range(20):
        R, t = so3_exp(rng.normal(size=3)), rng.normal(size=3) + [0, 0, 3 * plane]
        X, u = view(rng, R, t, plane=plane)
        if np.any(X @ R[2] + t[2] <= 0.5):
            continue
        Rd, td = dls(X, normalise(K, u))
        assert np.abs(Rd - R).max() < 1e-9 and np.abs(td - t).max() < 1e-8


def test_dls_reaches_rotations_by_pi_which_cayley_cannot():
    rng = np.random.default_rng(5)
    for axis in [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1), (1, -2, 0.5)]:
        R, t = so3_exp(np.pi * np.array(axis) / np.linalg.norm(axis)), np.array([0.1, 0.2, 10.0])
        X, u = view(rng, R, t)
        Rd, td = dls(X, normalise(K, u))
        assert np.abs(Rd - R).max() < 1e-9 and np.abs(td - t).max() < 1e-8


def test_every_stationary_point_is_a_root_of_the_three_cubics(rng):
    R, t = so3_exp(rng.normal(size=3) * 0.5), rng.normal(size=3)
    X, u = view(rng, R, t, n=30)
    x = normalise(K, u + rng.normal(size=u.shape))
    f = np.column_stack([x, np.ones(len(x))])
    M, _ = _cost_matrices(X, f / np.linalg.norm(f, axis=1, keepdims=True))
    F = np.einsum("ab,kabm->km", _C.T @ M @ _C, _G)
    s = _stationary_points(F)
    assert 1 <= len(s) <= 27
    values, _ = _monomial_values(s)
    scale = np.abs(F).max() * np.maximum(1, np.abs(s).max(axis=1)) ** 3
    assert np.all(np.abs(values @ F.T).max(axis=1) < 1e-9 * scale)


def test_dls_is_as_accurate_as_opencvs_sqpnp_with_noise(rng):
    ours, sqpnp, gap = [], [], []
    for _ in range(40):
        R, t = so3_exp(rng.normal(size=3)), rng.normal(size=3)
        X, u = view(rng, R, t, n=20)
        u = u + rng.normal(size=u.shape)
        Rd, _ = dls(X, normalise(K, u))
        _, rv, _ = cv2.solvePnP(X, u, K, None, flags=cv2.SOLVEPNP_SQPNP)
        R_cv = cv2.Rodrigues(rv)[0]
        ours.append(rotation_angle(Rd.T @ R))
        sqpnp.append(rotation_angle(R_cv.T @ R))
        gap.append(rotation_angle(Rd.T @ R_cv))
    # DLS drops the Cayley denominator from the cost, so it is near SQPnP's optimum, not on it
    assert np.median(ours) <= 1.1 * np.median(sqpnp) and np.median(gap) < 0.1 * np.median(sqpnp)


def test_dls_refuses_fewer_than_four_points(rng):
    with pytest.raises(ValueError, match="at least 4 points"):
        dls(rng.normal(size=(3, 3)), rng.normal(size=(3, 2)))


def test_pnp_ransac_with_dls_on_the_inliers(rng):
    R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
    X = (rng.uniform([-3, -2, 4], [3, 2, 30], size=(150, 3)) - t) @ R
    u = project(K, R, t, X) + rng.normal(size=(150, 2)) * 0.7
    u[:45] += rng.uniform(-80, 80, size=(45, 2))
    a, b = pnp_ransac(K, X, u, 3.0, nonminimal="dls"), pnp_ransac(K, X, u, 3.0, nonminimal="epnp")
    assert a.inliers[45:].mean() > 0.97 and a.inliers[:45].mean() < 0.1
    assert rotation_angle(a.R.T @ R) < np.radians(0.1) and np.linalg.norm(a.t - t) < 0.05
    assert rotation_angle(a.R.T @ b.R) < 1e-6  # the same LM optimum from either start
