"""The camera pose from a planar calibration board: OpenCV finds the inner corners, the project's PnP does the rest.

Per frame: ``cv2.findChessboardCorners`` and ``cv2.cornerSubPix`` (detection, not the object of study) give the
pixels of the (nx, ny) inner corners; the camera's lens model is inverted (:func:`undistort`); then
:func:`~.pnp.pnp_ransac` (P3P samples — the board is planar, so EPnP is not used — and LM on SE(3)) gives
``T_cam←world`` against the corners' world positions.

OpenCV orders the corners row by row but may start at either end (a 9 × 6 board looks the same turned by 180°).
The order is resolved without the ground truth: on the first frame with a detection, corner 0 is the one nearer
the image's top-left (the board's world origin is its upper-left inner corner); afterwards the order whose pose
is nearer the previous frame's pose (camera centre) is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slamarena.datasets.sequence import Camera

from .pnp import pnp_ransac
from .projection import undistort_radial_pixels

__all__ = ["detect_corners", "undistort", "board_poses", "BoardPoses"]


def detect_corners(image: np.ndarray, pattern: tuple[int, int]) -> np.ndarray | None:
    """The inner corners (nx·ny, 2) [px, distorted] of the board in a grey image, refined to sub-pixel; None if absent."""
    import cv2

    found, corners = cv2.findChessboardCorners(image, pattern)
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    return cv2.cornerSubPix(image, corners, (5, 5), (-1, -1), criteria).reshape(-1, 2).astype(float)


def undistort(camera: Camera, u: np.ndarray) -> np.ndarray:
    """Pixels of an ideal pinhole (n, 2) from the camera's measured pixels u (n, 2)."""
    if camera.distortion_model == "radial_pixels":
        return undistort_radial_pixels(camera.K, camera.distortion, u)
    return np.asarray(u, float)


@dataclass(frozen=True)
class BoardPoses:
    """Per frame: found (N,) bool, R (N, 3, 3) and t (N, 3) of T_cam←world (NaN where not found), the RMS
    reprojection error [px] (N,), and the PnP samples drawn (N,)."""

    found: np.ndarray
    R: np.ndarray
    t: np.ndarray
    rms: np.ndarray
    iterations: np.ndarray


def board_poses(
    camera: Camera, world: np.ndarray, pattern: tuple[int, int], threshold: float = 2.0, nonminimal: str = "epnp"
) -> BoardPoses:
    """PnP poses of every frame of ``camera`` from the board corners ``world`` ((nx·ny, 3), x fastest);
    ``nonminimal`` is :func:`~.pnp.pnp_ransac`'s solver on the inliers (EPnP refuses the planar board: then the
    best P3P pose starts LM; DLS takes it)."""
    n = len(camera)
    found = np.zeros(n, bool)
    R, t = np.full((n, 3, 3), np.nan), np.full((n, 3), np.nan)
    rms, iterations = np.full(n, np.nan), np.zeros(n, np.int64)
    previous = None
    for k in range(n):
        corners = detect_corners(camera.image(k), pattern)
        if corners is None:
            continue
        u = undistort(camera, corners)
        if previous is None and np.linalg.norm(u[-1]) < np.linalg.norm(u[0]):
            u = u[::-1]  # corner 0 nearest the top-left on the first frame
        results = [pnp_ransac(camera.K, world, v, threshold, nonminimal=nonminimal) for v in (u, u[::-1])]
        if previous is not None:
            centres = [np.linalg.norm(-r.R.T @ r.t - previous) for r in results]
            result = results[int(np.argmin(centres))]
        else:
            result = results[0]
        previous = -result.R.T @ result.t
        found[k], R[k], t[k], rms[k], iterations[k] = True, result.R, result.t, result.rms, result.iterations
    return BoardPoses(found, R, t, rms, iterations)
