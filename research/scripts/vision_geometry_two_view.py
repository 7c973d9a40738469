"""CPU time of our 5-point RANSAC + cheirality against OpenCV's on one synthetic problem (800 matches, 25 % outliers).

Run from the repository root: ``python research/scripts/vision_geometry_two_view.py`` (notebook
2026-11-28-vision-geometry); minimum of 5 repeats, one thread.
"""

from __future__ import annotations

import os

import numpy as np


def main() -> None:
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    import cv2

    from slamarena.estimators.vision.lie import so3_exp
    from slamarena.estimators.vision.two_view import essential_ransac
    from slamarena.experiments.benchmarks.vision import best_cpu

    cv2.setNumThreads(1)
    rng = np.random.default_rng(0)
    n, f = 800, 718.0
    R, t = so3_exp([0.01, 0.05, 0.0]), np.array([0.05, 0.02, 1.0])
    t /= np.linalg.norm(t)
    X = rng.uniform([-10, -3, 5], [10, 3, 60], (n, 3))
    X2 = X @ R.T + t
    x1 = X[:, :2] / X[:, 2:] + rng.normal(size=(n, 2)) * 0.5 / f
    x2 = X2[:, :2] / X2[:, 2:] + rng.normal(size=(n, 2)) * 0.5 / f
    x2[:200] += rng.uniform(-0.1, 0.1, (200, 2))
    essential_ransac(x1, x2, 1 / f)  # compile / warm up
    result, ours = best_cpu(lambda: essential_ransac(x1, x2, 1 / f), 5)

    def opencv():
        E, mask = cv2.findEssentialMat(x1, x2, np.eye(3), cv2.RANSAC, 0.999, 1 / f)
        return cv2.recoverPose(E[:3], x1, x2, np.eye(3), mask=mask.copy())

    _, theirs = best_cpu(opencv, 5)
    print(f"ours {ours * 1e3:.1f} ms ({result.iterations} samples), OpenCV {theirs * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
