"""The camera geometry written by the project, against OpenCV as the oracle and against the notes' claims."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from slamarena.estimators.vision.lie import rotation_angle, se3_exp, skew, so3_exp, so3_log
from slamarena.estimators.vision.matching import hamming_table, match
from slamarena.estimators.vision.pnp import OptimisationError, epnp, p3p, pnp_ransac, refine_pose
from slamarena.estimators.vision.projection import (
    distort_radial_pixels,
    jacobians,
    normalise,
    project,
    residuals,
    undistort_radial_pixels,
)
from slamarena.estimators.vision.ransac import iterations_needed
from slamarena.estimators.vision.triangulation import depths, triangulate_dlt, triangulate_midpoint
from slamarena.estimators.vision.two_view import (
    cheirality_counts,
    decompose_essential,
    eight_point,
    essential_ransac,
    five_point,
    relative_pose,
)

K = np.array([[718.856, 0.0, 607.1928], [0.0, 718.856, 185.2157], [0.0, 0.0, 1.0]])


def scene(rng, n=60):
    """Two cameras (camera 1 at the origin, camera 2 at T_2←1 = (R, t), ||t|| = 1) and n points in front of both."""
    while True:
        R, t = so3_exp(rng.normal(size=3) * 0.15), rng.normal(size=3)
        t /= np.linalg.norm(t)
        X = rng.uniform([-4, -3, 4], [4, 3, 15], size=(n, 3))
        X2 = X @ R.T + t
        if np.all(X2[:, 2] > 0.5):
            return R, t, X, X[:, :2] / X[:, 2:], X2[:, :2] / X2[:, 2:]


def essential_of(R, t):
    E = skew(t) @ R
    return E / np.linalg.norm(E)


def same_up_to_sign(A, B):
    return min(np.abs(A - B).max(), np.abs(A + B).max())


def test_so3_and_se3_maps_agree_with_rodrigues(rng):
    for phi in [*rng.normal(size=(20, 3)), np.array([1e-9, 0, 0]), np.array([0, np.pi - 1e-7, 0])]:
        R = so3_exp(phi)
        np.testing.assert_allclose(R, cv2.Rodrigues(phi)[0], atol=1e-12)
        np.testing.assert_allclose(so3_exp(so3_log(R)), R, atol=1e-6)
        theta = np.linalg.norm(phi) % (2 * np.pi)
        assert rotation_angle(R) == pytest.approx(min(theta, 2 * np.pi - theta), abs=1e-6)
    xi = rng.normal(size=6)
    R, t = se3_exp(xi)
    step = np.eye(4)
    for _ in range(1000):  # exp(ξ) = lim (I + ξ^/m)^m
        step = step @ (np.eye(4) + np.block([[skew(xi[3:]), xi[:3, None]], [np.zeros((1, 4))]]) / 1000)
    np.testing.assert_allclose(step[:3, 3], t, atol=5e-3)


def test_five_correspondences_are_the_minimum_and_give_the_true_essential_matrix(rng):
    for _ in range(30):
        R, t, _, x1, x2 = scene(rng, 5)
        solutions = five_point(x1, x2)
        assert 1 <= len(solutions) <= 10
        assert min(same_up_to_sign(E, essential_of(R, t)) for E in solutions) < 1e-8
        for E in solutions:  # every solution is an essential matrix satisfying the five constraints
            s = np.linalg.svd(E, compute_uv=False)
            assert s[0] - s[1] < 1e-6 and s[2] < 1e-6
            h1, h2 = np.c_[x1, np.ones(5)], np.c_[x2, np.ones(5)]
            assert np.abs(np.einsum("ni,ij,nj->n", h2, E, h1)).max() < 1e-10
    with pytest.raises(ValueError, match="at least 5"):
        five_point(x1[:4], x2[:4])


def test_five_point_solutions_are_opencvs(rng):
    for _ in range(20):
        _, _, _, x1, x2 = scene(rng, 5)
        ours = five_point(x1, x2)
        theirs = cv2.findEssentialMat(x1, x2, np.eye(3), method=cv2.RANSAC, threshold=1e-3)[0].reshape(-1, 3, 3)
        theirs = theirs / np.linalg.norm(theirs, axis=(1, 2), keepdims=True)
        assert len(ours) == len(theirs)
        for E in ours:
            assert min(same_up_to_sign(E, F) for F in theirs) < 1e-5


def test_eight_point_is_exact_without_noise_and_needs_eight(rng):
    R, t, _, x1, x2 = scene(rng, 8)
    assert same_up_to_sign(eight_point(x1, x2), essential_of(R, t)) < 1e-8
    with pytest.raises(ValueError, match="at least 8"):
        eight_point(x1[:7], x2[:7])


def test_exactly_one_of_the_four_decompositions_passes_cheirality(rng):
    for _ in range(20):
        R, t, X, x1, x2 = scene(rng)
        E = essential_of(R, t)
        candidates = decompose_essential(E)
        ocv_R1, ocv_R2, ocv_t = cv2.decomposeEssentialMat(E)
        for Rc, tc in candidates:
            assert min(np.abs(Rc - ocv_R1).max(), np.abs(Rc - ocv_R2).max()) < 1e-9
            assert same_up_to_sign(tc, ocv_t.ravel()) < 1e-9
            np.testing.assert_allclose(np.linalg.det(Rc), 1.0)
        counts = cheirality_counts(x1, x2, candidates)
        assert sorted(counts.tolist()) == [0, 0, 0, len(X)]
        R_best, t_best, n = relative_pose(E, x1, x2)
        assert n == len(X) and np.abs(R_best - R).max() < 1e-9 and np.abs(t_best - t).max() < 1e-9
        _, R_cv, t_cv, _ = cv2.recoverPose(E, x1, x2, np.eye(3))
        np.testing.assert_allclose(R_best, R_cv, atol=1e-9)
        np.testing.assert_allclose(t_best, t_cv.ravel(), atol=1e-9)


def test_essential_ransac_with_outliers_matches_the_truth_and_opencv(rng):
    R, t, _, x1, x2 = scene(rng, 200)
    sigma = 0.5 / K[0, 0]
    x1n, x2n = x1 + rng.normal(size=x1.shape) * sigma, x2 + rng.normal(size=x2.shape) * sigma
    x2n[:60] = rng.uniform(-0.5, 0.5, size=(60, 2))
    result = essential_ransac(x1n, x2n, threshold=2 / K[0, 0])
    assert rotation_angle(result.R.T @ R) < np.radians(0.2) and result.t @ t > 0.999
    assert result.inliers[60:].mean() > 0.95 and result.inliers[:60].mean() < 0.1
    E_cv, _ = cv2.findEssentialMat(x1n, x2n, np.eye(3), method=cv2.RANSAC, threshold=2 / K[0, 0], prob=0.999)
    _, R_cv, t_cv, _ = cv2.recoverPose(E_cv, x1n, x2n, np.eye(3))
    assert rotation_angle(result.R.T @ R_cv) < np.radians(0.2) and result.t @ t_cv.ravel() > 0.999
    assert iterations_needed(0.5, 5, 0.99, 10**6) == 146 and iterations_needed(1.0, 5, 0.99, 100) == 1


def test_triangulation_dlt_is_opencvs_and_midpoint_is_exact_without_noise(rng):
    R, t, X, x1, x2 = scene(rng)
    pose1, pose2 = (np.eye(3), np.zeros(3)), (R, t)
    np.testing.assert_allclose(triangulate_dlt(x1, x2, pose1, pose2), X, atol=1e-9)
    np.testing.assert_allclose(triangulate_midpoint(x1, x2, pose1, pose2), X, atol=1e-9)
    noisy1, noisy2 = x1 + rng.normal(size=x1.shape) * 1e-3, x2 + rng.normal(size=x2.shape) * 1e-3
    ours = triangulate_dlt(noisy1, noisy2, pose1, pose2)
    h = cv2.triangulatePoints(np.c_[np.eye(3), np.zeros(3)], np.c_[R, t], noisy1.T, noisy2.T)
    np.testing.assert_allclose(ours, (h[:3] / h[3]).T, rtol=1e-6, atol=1e-8)
    assert np.median(np.linalg.norm(triangulate_midpoint(noisy1, noisy2, pose1, pose2) - ours, axis=1)) < 0.1
    assert np.all(depths(X, pose1) > 0)


def test_projection_is_opencvs_and_jacobians_match_finite_differences(rng):
    R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
    X = (rng.uniform([-3, -2, 4], [3, 2, 20], size=(10, 3)) - t) @ R
    np.testing.assert_allclose(project(K, R, t, X), cv2.projectPoints(X, cv2.Rodrigues(R)[0], t, K, None)[0][:, 0])
    u = project(K, R, t, X) + rng.normal(size=(10, 2))
    J_pose, J_point = jacobians(K, R, t, X)
    h = 1e-6
    for k in range(6):
        dR, dt = se3_exp(h * np.eye(6)[k])
        plus = residuals(K, dR @ R, dR @ t + dt, X, u)
        dR, dt = se3_exp(-h * np.eye(6)[k])
        minus = residuals(K, dR @ R, dR @ t + dt, X, u)
        np.testing.assert_allclose((plus - minus) / (2 * h), J_pose[:, :, k], rtol=1e-5, atol=1e-4)
    for k in range(3):
        d = h * np.eye(3)[k]
        numeric = (residuals(K, R, t, X + d, u) - residuals(K, R, t, X - d, u)) / (2 * h)
        np.testing.assert_allclose(numeric, J_point[:, :, k], rtol=1e-5, atol=1e-4)


def test_radial_pixel_distortion_round_trip():
    k = np.array([-1.6774e-06, 2.5847e-12])
    Kb = np.array([[420.5, 0, 355.2], [0, 420.6, 250.3], [0, 0, 1]])
    u = np.array([[355.2, 250.3], [10.0, 10.0], [740.0, 470.0]])
    np.testing.assert_allclose(undistort_radial_pixels(Kb, k, distort_radial_pixels(Kb, k, u)), u, atol=1e-9)
    assert np.linalg.norm(distort_radial_pixels(Kb, k, u)[1] - u[1]) > 20  # the corners move by tens of pixels


def test_p3p_returns_up_to_four_poses_as_many_as_opencv_and_the_true_one(rng):
    counts = []
    for _ in range(300):
        R, t = so3_exp(rng.normal(size=3)), rng.normal(size=3)
        Xc = rng.uniform([-3, -3, 2], [3, 3, 8], size=(3, 3))
        X, x = (Xc - t) @ R, Xc[:, :2] / Xc[:, 2:]
        poses = p3p(X, x)
        n_cv, _, _ = cv2.solveP3P(X, x, np.eye(3), None, flags=cv2.SOLVEPNP_P3P)
        assert len(poses) == n_cv
        counts.append(len(poses))
        assert min(np.abs(Rs - R).max() + np.abs(ts - t).max() for Rs, ts in poses) < 1e-6
        for Rs, ts in poses:  # every solution reprojects the three points exactly
            np.testing.assert_allclose(residuals(np.eye(3), Rs, ts, X, x), 0, atol=1e-8)
    assert max(counts) == 4 and min(counts) >= 1


def test_epnp_is_exact_without_noise_and_as_accurate_as_opencvs_with_noise(rng):
    ours_err, cv_err = [], []
    for trial in range(40):
        R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
        Xc = rng.uniform([-3, -2, 4], [3, 2, 20], size=(20, 3))
        X = (Xc - t) @ R
        u = project(K, R, t, X)
        if trial == 0:
            Re, te = epnp(X, normalise(K, u))
            assert np.abs(Re - R).max() < 1e-9 and np.abs(te - t).max() < 1e-8
        u = u + rng.normal(size=u.shape)
        Re, _ = epnp(X, normalise(K, u))
        ok, rv, _ = cv2.solvePnP(X, u, K, None, flags=cv2.SOLVEPNP_EPNP)
        ours_err.append(rotation_angle(Re.T @ R))
        cv_err.append(rotation_angle(cv2.Rodrigues(rv)[0].T @ R))
    assert np.median(ours_err) <= 1.2 * np.median(cv_err)
    with pytest.raises(ValueError, match="non-coplanar"):
        epnp(np.c_[rng.normal(size=(8, 2)), np.zeros(8)], rng.normal(size=(8, 2)))


def test_pnp_ransac_with_outliers_then_lm_reaches_opencvs_least_squares_pose(rng):
    R, t = so3_exp(rng.normal(size=3) * 0.3), rng.normal(size=3)
    X = (rng.uniform([-3, -2, 4], [3, 2, 30], size=(150, 3)) - t) @ R
    u = project(K, R, t, X) + rng.normal(size=(150, 2)) * 0.7
    u[:45] += rng.uniform(-80, 80, size=(45, 2))
    for minimal in ("p3p", "epnp"):
        result = pnp_ransac(K, X, u, threshold=3.0, minimal=minimal)
        assert result.inliers[45:].mean() > 0.97 and result.inliers[:45].mean() < 0.1
        assert rotation_angle(result.R.T @ R) < np.radians(0.1) and np.linalg.norm(result.t - t) < 0.05
        inl = result.inliers
        _, rv, tv = cv2.solvePnP(X[inl], u[inl], K, None, cv2.Rodrigues(result.R)[0], result.t.copy(), True)
        R_cv, _ = cv2.Rodrigues(rv)
        R_lm, t_lm, rms = refine_pose(K, result.R, result.t, X[inl], u[inl])
        assert rotation_angle(R_lm.T @ R_cv) < 1e-5 and np.linalg.norm(t_lm - tv.ravel()) < 1e-5
        assert rms == pytest.approx(np.sqrt(np.mean(np.sum(residuals(K, R_lm, t_lm, X[inl], u[inl]) ** 2, 1))))


def test_refine_pose_refuses_points_behind_the_camera(rng):
    X = np.array([[0, 0, -5.0], [1, 0, 5], [0, 1, 5], [1, 1, 6]])
    with pytest.raises(OptimisationError, match="1 of 4 points behind the camera"):
        refine_pose(K, np.eye(3), np.zeros(3), X, np.zeros((4, 2)))


def test_hamming_matching_is_opencvs_brute_force_matcher(rng):
    a = rng.integers(0, 256, size=(300, 32), dtype=np.uint8)
    b = np.concatenate([a[:150] ^ (rng.random((150, 32)) < 0.05) * np.uint8(1), rng.integers(0, 256, (100, 32))])
    b = b.astype(np.uint8)
    D = hamming_table(a, b)
    ref = np.array([[cv2.norm(p, q, cv2.NORM_HAMMING) for q in b] for p in a[:20]])
    np.testing.assert_array_equal(D[:20], ref)
    literal = np.bitwise_count(a[:, None, :] ^ b[None, :, :]).sum(axis=2)  # the vectorised form
    np.testing.assert_array_equal(D, literal)
    i, j = match(a, b, ratio=None, mutual=True)
    cross = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(a, b)
    assert sorted(zip(i.tolist(), j.tolist())) == sorted((m.queryIdx, m.trainIdx) for m in cross)
    i, j = match(a, b, ratio=0.8, mutual=False)
    knn = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(a, b, k=2)
    expected = sorted((m.queryIdx, m.trainIdx) for m, n in knn if m.distance < 0.8 * n.distance)
    assert sorted(zip(i.tolist(), j.tolist())) == expected
    assert set(zip(i.tolist(), j.tolist())) >= {(k, k) for k in range(150)}


def test_the_two_backends_match_triangulate_and_solve_alike(rng):
    from slamarena.estimators.vision.backends import OPENCV, OURS

    a = rng.integers(0, 256, size=(200, 32), dtype=np.uint8)
    b = np.concatenate([a[:120] ^ (rng.random((120, 32)) < 0.03) * np.uint8(1), rng.integers(0, 256, (80, 32))])
    b = b.astype(np.uint8)
    allowed = rng.random((200, 200)) < 0.7
    allowed[np.arange(120), np.arange(120)] = True
    for mask in (None, allowed):
        assert sorted(zip(*map(list, OURS.match(a, b, 0.8, 64, mask)))) == sorted(
            zip(*map(list, OPENCV.match(a, b, 0.8, 64, mask)))
        )
    R, t, X, x1, x2 = scene(rng)
    pose1, pose2 = (np.eye(3), np.zeros(3)), (R, t)
    np.testing.assert_allclose(
        OPENCV.triangulate(x1, x2, pose1, pose2), OURS.triangulate(x1, x2, pose1, pose2), atol=1e-6
    )
    u = project(K, R, t, X)
    for backend in (OURS, OPENCV):
        pose = backend.pnp(K, X, u, 2.0, 0)
        assert rotation_angle(pose.R.T @ R) < 1e-6 and pose.inliers.all()
        two_view = backend.essential(x1, x2, 1e-3, 0)
        assert rotation_angle(two_view.R.T @ R) < 1e-6 and two_view.t @ t > 1 - 1e-9


def test_paired_cheirality_and_batched_sampson_equal_their_literal_forms(rng):
    from slamarena.estimators.vision.two_view import (
        _homogeneous,
        _paired_cheirality_counts,
        _sampson_all,
        sampson_distance,
    )

    for _ in range(10):
        R, t, _, x1, x2 = scene(rng)
        x2 = x2 + rng.normal(size=x2.shape) * 1e-3  # some points fall behind under the wrong decompositions
        candidates = decompose_essential(essential_of(R, t))
        np.testing.assert_array_equal(
            _paired_cheirality_counts(x1, x2, candidates), cheirality_counts(x1, x2, candidates)
        )
        Es = five_point(x1[:5], x2[:5])
        np.testing.assert_allclose(
            _sampson_all(Es, _homogeneous(x1), _homogeneous(x2)),
            [sampson_distance(E, x1, x2) for E in Es],
            rtol=1e-9,
            atol=1e-20,
        )
