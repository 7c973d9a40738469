"""notebook/2026-11-28-vision-2.md: the stereo depth on KITTI 00 checked without the trajectory score.

Run from the repository root: ``python research/scripts/vision_stereo_depth_checks.py ground 0 3 6 9 15 40 80`` or
``... disparity 0 30 60 90``.

``ground K…``: for frame k, the camera height above the road plane (RANSAC plane through the points of the road in
front of the car: rows > 260, columns 450–800) (a) from OpenCV's dense stereo (StereoSGBM, sub-pixel disparities, the
staged baseline) and (b) from the left frames k and k + 1 alone (Farnebäck optical flow, DLT with the ground-truth
motion T_k+1←k). KITTI's cameras are mounted 1.65 m above the road. (b)/(a) ≠ 1 means the ground-truth step is not
the step the images show.

``disparity K…``: our stereo matches' disparities (StereoVOParams' pipeline, with and without the sub-pixel
refinement) against SGBM's at the same left pixel: median and 90th percentile of |d_ours − d_SGBM| [px].
"""

from __future__ import annotations

import sys

import cv2
import numpy as np


def _sgbm():
    return cv2.StereoSGBM_create(
        minDisparity=0, numDisparities=128, blockSize=7, P1=8 * 49, P2=32 * 49, uniquenessRatio=10,
        speckleWindowSize=100, speckleRange=2,
    )  # fmt: skip


def _plane_height(P: np.ndarray, rng) -> float:
    best = None
    for _ in range(200):
        s = P[rng.choice(len(P), 3, replace=False)]
        n = np.cross(s[1] - s[0], s[2] - s[0])
        if np.linalg.norm(n) < 1e-9:
            continue
        n /= np.linalg.norm(n)
        inliers = np.abs(P @ n - n @ s[0]) < 0.05 * np.maximum(1, np.abs(P[:, 2]) / 10)
        if best is None or inliers.sum() > best.sum():
            best = inliers
    Q = P[best]
    mu = Q.mean(axis=0)
    return float(abs(np.linalg.svd(Q - mu, full_matrices=False)[2][-1] @ mu))


def ground(frames: list[int]) -> None:
    import slamarena
    from slamarena.estimators.vision.triangulation import triangulate_dlt

    cv2.setNumThreads(1)
    camera = slamarena.load("kitti:00", frames=100).camera
    K, b, G = camera.K, camera.baseline, camera.ground_truth
    fx, cx, cy = K[0, 0], K[0, 2], K[1, 2]
    rng = np.random.default_rng(0)
    v, u = np.mgrid[0:376, 0:1241]
    region = (v > 260) & (u > 450) & (u < 800)
    for k in frames:
        D = _sgbm().compute(camera.image(k), camera.image(k, "right")).astype(float) / 16
        sel = region & (D > 1)
        Z = fx * b / D[sel]
        stereo = _plane_height(np.column_stack([(u[sel] - cx) * Z / fx, (v[sel] - cy) * Z / fx, Z]), rng)
        flow = cv2.calcOpticalFlowFarneback(camera.image(k), camera.image(k + 1), None, 0.5, 4, 21, 5, 7, 1.5, 0)
        uu, vv = u[region][::7], v[region][::7]
        f = flow[vv, uu]
        x0 = np.column_stack([(uu - cx) / fx, (vv - cy) / fx])
        x1 = np.column_stack([(uu + f[:, 0] - cx) / fx, (vv + f[:, 1] - cy) / fx])
        T = np.linalg.inv(G[k + 1]) @ G[k]
        X = triangulate_dlt(x0, x1, (np.eye(3), np.zeros(3)), (T[:3, :3], T[:3, 3]))
        ok = np.isfinite(X).all(axis=1) & (X[:, 2] > 2) & (X[:, 2] < 30)
        motion = _plane_height(X[ok], rng)
        print(
            f"frame {k:3d}: height from stereo (SGBM) {stereo:.3f} m; from frames k, k+1 with the ground-truth motion "
            f"{motion:.3f} m; ratio {stereo / motion:.3f}; ground-truth step {np.linalg.norm(T[:3, 3]):.3f} m",
            flush=True,
        )


def disparity(frames: list[int]) -> None:
    import slamarena
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_points

    cv2.setNumThreads(1)
    camera = slamarena.load("kitti:00", frames=100).camera
    for k in frames:
        D = _sgbm().compute(camera.image(k), camera.image(k, "right")).astype(float) / 16
        for subpixel in (False, True):
            ul, ur, X, _ = stereo_points(camera, k, StereoVOParams(subpixel=subpixel))
            ref = D[np.rint(ul[:, 1]).astype(int), np.rint(ul[:, 0]).astype(int)]
            ok = ref > 1
            error = (ul[ok, 0] - ur[ok]) - ref[ok]
            print(
                f"frame {k:3d} subpixel={subpixel!s:5}: {ok.sum()} points with an SGBM disparity; |d - d_SGBM| median "
                f"{np.median(np.abs(error)):.3f} px, p90 {np.percentile(np.abs(error), 90):.3f} px, "
                f"median signed {np.median(error):+.3f} px",
                flush=True,
            )


def main(argv: list[str]) -> None:
    {"ground": ground, "disparity": disparity}[argv[0]]([int(a) for a in argv[1:]])


if __name__ == "__main__":
    main(sys.argv[1:])
