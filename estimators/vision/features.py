"""ORB features (OpenCV's detector and descriptor: not the object of study) and their repeatability under a warp.

:func:`orb` returns keypoint pixels (n, 2) and descriptors (n, 32) uint8. :func:`warp_match_rate` measures how well
ORB + :func:`~.matching.match` survive an image rotation by ``angle`` and scaling by ``scale`` about the centre:
the image is warped by the similarity A (2, 3), features are detected in both, matched (ratio test, mutual check),
and a match (i, j) is correct when ``||A u_i − u'_j|| ≤ tolerance`` px. The rate is correct matches over the
keypoints of the original whose warped position lies inside the warped image.
"""

from __future__ import annotations

import cv2
import numpy as np

from slamarena.params import Field, Params

from .matching import match

__all__ = ["FeatureParams", "detect", "orb", "warp_match_rate"]


class FeatureParams(Params):
    """Features and their matching, shared by the VO pipelines: ORB (OpenCV) and Hamming matching (ratio test,
    mutual check, a distance cap)."""

    n_features: int = Field(2000, ge=50, description="ORB features per image")
    ratio: float = Field(0.8, gt=0, le=1, description="Lowe's ratio test")
    max_distance: int = Field(64, ge=0, le=256, description="largest Hamming distance of a match [bits]")
    grid: tuple[int, int] = Field(
        (12, 4), description="buckets (columns, rows) over the image (0, 0: none); see :func:`detect`"
    )


def detect(image: np.ndarray, params: FeatureParams) -> tuple[np.ndarray, np.ndarray]:
    """A pipeline's features: :func:`orb` with ``n_features``, or, with a ``grid`` of c × r buckets, ``n_features``
    of ``2 n_features`` detected taken in turns from the buckets (each bucket's strongest by FAST response, then each
    one's second, …) — the spread a PnP and a bundle adjustment need, where ORB's own ranking crowds the features
    into the most textured part of the image."""
    columns, rows = params.grid
    if columns * rows == 0:
        return orb(image, params.n_features)
    detector = cv2.ORB_create(nfeatures=2 * params.n_features)
    keypoints = detector.detect(image, None)
    if not keypoints:
        return np.zeros((0, 2)), np.zeros((0, 32), np.uint8)
    u = np.array([k.pt for k in keypoints], dtype=float)
    response = np.array([k.response for k in keypoints])
    h, w = image.shape
    cell = np.minimum((u[:, 0] * columns / w).astype(int), columns - 1) * rows + np.minimum(
        (u[:, 1] * rows / h).astype(int), rows - 1
    )
    order = np.lexsort((-response, cell))
    start = np.searchsorted(cell[order], cell[order])  # first position of each keypoint's bucket
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order)) - start  # 0 for the strongest of its bucket
    keep = np.sort(np.lexsort((-response, rank))[: params.n_features])
    kept, descriptors = detector.compute(image, [keypoints[k] for k in keep])  # descriptors of the kept ones only
    if descriptors is None:
        return np.zeros((0, 2)), np.zeros((0, 32), np.uint8)
    return np.array([k.pt for k in kept], dtype=float), descriptors


def orb(image: np.ndarray, n_features: int = 2000, **options) -> tuple[np.ndarray, np.ndarray]:
    """ORB keypoints (n, 2) [px] and descriptors (n, 32) uint8 of a grey image (options: cv2.ORB_create's)."""
    keypoints, descriptors = cv2.ORB_create(nfeatures=n_features, **options).detectAndCompute(image, None)
    if descriptors is None:
        return np.zeros((0, 2)), np.zeros((0, 32), np.uint8)
    return np.array([k.pt for k in keypoints], dtype=float), descriptors


def warp_match_rate(
    image: np.ndarray, angle_deg: float, scale: float, n_features: int = 2000, tolerance: float = 3.0
) -> dict:
    """Correct matches / visible keypoints after rotating by ``angle_deg`` and scaling by ``scale``."""
    h, w = image.shape
    A = cv2.getRotationMatrix2D((w / 2, h / 2), angle_deg, scale)
    warped = cv2.warpAffine(image, A, (w, h))
    u, d = orb(image, n_features)
    v, e = orb(warped, n_features)
    moved = u @ A[:, :2].T + A[:, 2]
    visible = (moved[:, 0] >= 0) & (moved[:, 0] < w) & (moved[:, 1] >= 0) & (moved[:, 1] < h)
    i, j = match(d, e)
    correct = np.linalg.norm(moved[i] - v[j], axis=1) <= tolerance
    return {
        "angle_deg": angle_deg,
        "scale": scale,
        "visible": int(visible.sum()),
        "matches": int(len(i)),
        "correct": int(correct.sum()),
        "rate": float(correct.sum() / max(visible.sum(), 1)),
        "precision": float(correct.mean()) if len(i) else 0.0,
    }
