"""Per-problem CPU time of our PnP against OpenCV's on the ``--quick`` PnP problems of ``slamarena bench vision``.

Run from the repository root: ``python research/scripts/vision_geometry_profile.py`` (notebook
2026-11-28-vision-geometry): 12 problems (KITTI 00 stereo frames k = 0, 8, …, 88 → k + 3), minimum of 5 repeats.
"""

from __future__ import annotations

import os

import numpy as np


def main() -> None:
    for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[variable] = "1"
    import cv2

    from slamarena.datasets import load
    from slamarena.estimators.vision.features import orb
    from slamarena.estimators.vision.matching import match
    from slamarena.estimators.vision.pnp import epnp, p3p, pnp_ransac
    from slamarena.estimators.vision.projection import normalise
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_points
    from slamarena.experiments.benchmarks.vision import best_cpu

    cv2.setNumThreads(1)
    camera = load("kitti:00").camera.select(slice(0, 100))
    K = camera.K
    total = dict.fromkeys(("ransac", "ransac_cv", "epnp", "epnp_cv", "p3p", "p3p_cv"), 0.0)
    for i in range(0, 96, 8):
        _, _, X, d = stereo_points(camera, i, StereoVOParams())
        u, e = orb(camera.image(i + 3))
        a, b = match(d, e)
        X, u = X[a], u[b]
        result, t = best_cpu(lambda: pnp_ransac(K, X, u, 2.0, "p3p", 0.999, 1000, seed=i), 5)

        def opencv():
            _, r, tv, inl = cv2.solvePnPRansac(
                X, u, K, None, iterationsCount=1000, reprojectionError=2.0, confidence=0.999, flags=cv2.SOLVEPNP_P3P
            )
            inl = inl.ravel()
            return cv2.solvePnP(X[inl], u[inl], K, None, r, tv, True, cv2.SOLVEPNP_ITERATIVE)

        _, t_cv = best_cpu(opencv, 5)
        Xc, uc = X[result.inliers], u[result.inliers]
        xc = normalise(K, uc)
        _, t_e = best_cpu(lambda: epnp(Xc, xc), 5)
        _, t_e_cv = best_cpu(lambda: cv2.solvePnP(Xc, uc, K, None, flags=cv2.SOLVEPNP_EPNP), 5)
        _, t_p = best_cpu(lambda: p3p(Xc[:3], xc[:3]), 50)
        _, t_p_cv = best_cpu(lambda: cv2.solveP3P(Xc[:3], xc[:3], np.eye(3), None, flags=cv2.SOLVEPNP_P3P), 50)
        for key, value in zip(total, (t, t_cv, t_e, t_e_cv, t_p, t_p_cv)):
            total[key] += value
        print(f"frames {i}-{i + 3}: {len(X)} matches, {result.inliers.sum()} inliers, {result.iterations} samples")
    print({k: round(v * 1e3, 2) for k, v in total.items()}, "ms")
    for name in ("ransac", "epnp", "p3p"):
        print(f"{name}: ours / OpenCV {total[name] / total[name + '_cv']:.2f}")


if __name__ == "__main__":
    main()
