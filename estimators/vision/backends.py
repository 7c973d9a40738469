"""The geometry a VO pipeline calls, from one of two sources: the project's (``ours``) or OpenCV's alone (``opencv``).

The pipelines (:mod:`.stereo_vo`, :mod:`.mono_vo`) are the same for both; only these five operations differ, so a
table row "OpenCV baseline" measures OpenCV's geometry inside the same tracking and keyframe logic.

============  =================================================  ===================================================
operation     ours                                               opencv
============  =================================================  ===================================================
match         :func:`.matching.match` (ratio, mutual)            ``cv2.BFMatcher(NORM_HAMMING).knnMatch`` (k = 2,
                                                                 masked) both ways + the ratio test, mutual check
triangulate   :func:`.triangulation.triangulate_dlt`             ``cv2.triangulatePoints``
pnp           :func:`.pnp.pnp_ransac` (P3P, LM)                  ``cv2.solvePnPRansac(P3P)`` + ``cv2.solvePnP``
                                                                 (iterative LM) on its inliers
essential     :func:`.two_view.essential_ransac` (5-point)       ``cv2.findEssentialMat(RANSAC)`` + ``cv2.recoverPose``
============  =================================================  ===================================================

Shapes: descriptors (n, 32) uint8; normalised points x (n, 2); pixels u (n, 2); world points X (n, 3); a pose
(R, t) is ``T_cam←world``. ``allowed`` (n₁, n₂) bool, optional, rules descriptor pairs out of a match (stereo rows).
``match_candidates`` is the same match restricted to the candidate pairs (i (c,), j (c,)) — the pairs a rectified
pair allows, a few per row out of n₁ n₂ —: ours computes the c distances alone and takes, per row and per column,
the nearest candidate (ties to the lower index, as ``argmin``) and the second nearest (absent: the largest
distance), which is ``match`` with ``allowed`` true exactly on the candidates (test); OpenCV's builds that mask.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .matching import hamming_table, match_table
from .pnp import pnp_ransac
from .triangulation import triangulate_dlt
from .two_view import essential_ransac

__all__ = ["Pose", "OURS", "OPENCV", "BACKENDS", "Backend"]


@dataclass(frozen=True)
class Pose:
    """A pipeline's pose estimate: (R, t) = T_cam←world and the inlier mask (n,)."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray


class Backend:
    """The project's geometry."""

    name = "ours"

    def match(
        self, a: np.ndarray, b: np.ndarray, ratio: float, max_distance: int, allowed: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        if len(a) == 0 or len(b) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        D = hamming_table(a, b)
        if allowed is not None:
            D = np.where(allowed, D, np.iinfo(D.dtype).max)
        return match_table(D, ratio, True, max_distance)

    def match_candidates(
        self, a: np.ndarray, b: np.ndarray, i: np.ndarray, j: np.ndarray, ratio: float, max_distance: int
    ) -> tuple[np.ndarray, np.ndarray]:
        if len(i) == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        wa, wb = (np.ascontiguousarray(d, dtype=np.uint8).view(np.uint64) for d in (a, b))
        D = np.bitwise_count(wa[i] ^ wb[j]).sum(axis=1, dtype=np.int64)  # (c,)
        by_row = np.lexsort((j, D, i))  # each row's candidates, nearest first, ties to the lower column
        first = np.r_[True, i[by_row][1:] != i[by_row][:-1]]
        at = np.flatnonzero(first)
        after = np.minimum(at + 1, len(by_row) - 1)
        best, runner_up = by_row[at], by_row[after]  # candidate indices, one per row that has candidates
        second = np.where((after > at) & (i[runner_up] == i[best]), D[runner_up], np.iinfo(np.uint16).max)
        by_column = np.lexsort((i, D, j))
        column_first = by_column[np.r_[True, j[by_column][1:] != j[by_column][:-1]]]
        nearest_row = np.full(len(b), -1)
        nearest_row[j[column_first]] = i[column_first]
        keep = (D[best] <= max_distance) & (D[best] < ratio * second) & (nearest_row[j[best]] == i[best])
        return i[best][keep], j[best][keep]

    def triangulate(self, x1: np.ndarray, x2: np.ndarray, pose1, pose2) -> np.ndarray:
        return triangulate_dlt(x1, x2, pose1, pose2)

    def pnp(self, K: np.ndarray, X: np.ndarray, u: np.ndarray, threshold: float, seed: int) -> Pose | None:
        try:
            result = pnp_ransac(K, X, u, threshold, seed=seed)
        except ValueError:
            return None
        return Pose(result.R, result.t, result.inliers)

    def essential(self, x1: np.ndarray, x2: np.ndarray, threshold: float, seed: int) -> Pose | None:
        try:
            result = essential_ransac(x1, x2, threshold, seed=seed)
        except ValueError:
            return None
        return Pose(result.R, result.t, result.inliers)


class OpenCVBackend(Backend):
    """OpenCV's functions alone."""

    name = "opencv"

    def match(self, a, b, ratio, max_distance, allowed=None) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        if len(a) < 2 or len(b) < 2:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
        mask = None if allowed is None else allowed.astype(np.uint8)

        def nearest(query, train, mask):
            out = np.full(len(query), -1)
            for pair in matcher.knnMatch(query, train, k=2, mask=mask):
                if len(pair) == 2 and pair[0].distance <= max_distance and pair[0].distance < ratio * pair[1].distance:
                    out[pair[0].queryIdx] = pair[0].trainIdx
                elif len(pair) == 1 and pair[0].distance <= max_distance:
                    out[pair[0].queryIdx] = pair[0].trainIdx
            return out

        forward = nearest(a, b, mask)
        backward = nearest(b, a, None if mask is None else np.ascontiguousarray(mask.T))
        i = np.flatnonzero(forward >= 0)
        i = i[backward[forward[i]] == i]
        return i, forward[i]

    def match_candidates(self, a, b, i, j, ratio, max_distance) -> tuple[np.ndarray, np.ndarray]:
        allowed = np.zeros((len(a), len(b)), bool)
        allowed[i, j] = True
        return self.match(a, b, ratio, max_distance, allowed)

    def triangulate(self, x1, x2, pose1, pose2) -> np.ndarray:
        import cv2

        P1, P2 = (np.column_stack([R, np.asarray(t).reshape(3)]) for R, t in (pose1, pose2))
        h = cv2.triangulatePoints(P1, P2, np.asarray(x1, float).T, np.asarray(x2, float).T)
        with np.errstate(divide="ignore", invalid="ignore"):
            return (h[:3] / h[3]).T

    def pnp(self, K, X, u, threshold, seed) -> Pose | None:
        import cv2

        cv2.setRNGSeed(seed)
        if len(X) < 4:
            return None
        ok, r, t, inliers = cv2.solvePnPRansac(
            X, u, K, None, iterationsCount=1000, reprojectionError=threshold, confidence=0.999, flags=cv2.SOLVEPNP_P3P
        )
        if not ok or inliers is None or len(inliers) < 4:
            return None
        inliers = inliers.ravel()
        _, r, t = cv2.solvePnP(X[inliers], u[inliers], K, None, r, t, True, cv2.SOLVEPNP_ITERATIVE)
        mask = np.zeros(len(X), bool)
        mask[inliers] = True
        return Pose(cv2.Rodrigues(r)[0], t.ravel(), mask)

    def essential(self, x1, x2, threshold, seed) -> Pose | None:
        import cv2

        cv2.setRNGSeed(seed)
        if len(x1) < 5:
            return None
        E, mask = cv2.findEssentialMat(x1, x2, np.eye(3), cv2.RANSAC, 0.999, threshold)
        if E is None:
            return None
        _, R, t, mask = cv2.recoverPose(E[:3], x1, x2, np.eye(3), mask=mask)
        return Pose(R, t.ravel(), mask.ravel() > 0)


OURS = Backend()
OPENCV = OpenCVBackend()
BACKENDS = {"ours": OURS, "opencv": OPENCV}
