"""The UZH "Vision Algorithms for Mobile Robotics" checkerboard sequence: a hand-held camera around a planar board.

A directory holds::

    images/img_0001.jpg …   consecutive frames (frame k ↔ img_{k+1:04d}.jpg)
    K.txt                   the 3 × 3 intrinsic matrix
    D.txt                   k1 k2 of the radial model in pixel units (:class:`Camera`, ``radial_pixels``)
    poses.txt               per frame ωx ωy ωz tx ty tz: the Rodrigues vector and translation of T_cam←world

The world frame sits at the board's upper-left inner corner (x along its rows, y along its columns, z into the
board); the board has 9 × 6 inner corners 4 cm apart, corner (i, j) at (0.04 i, 0.04 j, 0) (:func:`board_corners`).
The reader stores the ground truth as ``T_world←cam`` (the inverse of the file's pose), as every
:class:`Camera` does. There are no timestamps: ``t`` is the frame index (``meta`` says so).

Catalogued: ``vamr:checkerboard``; any copy: ``vamr:<dir>``.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np

from slamarena.params import Field, Params, with_params

from ..errors import DataFormatError
from ..sequence import Camera, Sequence
from ..source import Layout, SourceParams, joined
from ._text import check_finite, numeric_table

__all__ = ["VamrParams", "VamrSource", "read", "board_corners", "rodrigues"]

#: the board: inner corners along x (rows) and y (columns), their spacing [m]
BOARD = (9, 6, 0.04)


def board_corners() -> np.ndarray:
    """(54, 3) world positions of the inner corners, corner (i, j) at row ``j * 9 + i`` (x fastest)."""
    nx, ny, step = BOARD
    j, i = np.mgrid[0:ny, 0:nx]
    return np.column_stack([step * i.ravel(), step * j.ravel(), np.zeros(nx * ny)])


def rodrigues(omega: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations of the Rodrigues vectors ``omega`` (N, 3): R = I + sin θ [k]× + (1 − cos θ) [k]×²."""
    omega = np.asarray(omega, dtype=float).reshape(-1, 3)
    theta = np.linalg.norm(omega, axis=1)
    k = omega / np.where(theta > 0, theta, 1.0)[:, None]
    W = np.zeros((len(omega), 3, 3))
    W[:, 0, 1], W[:, 0, 2], W[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    W -= W.transpose(0, 2, 1)
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    return np.eye(3) + s * W + (1 - c) * W @ W


class VamrParams(Params):
    """Options of the checkerboard reader."""

    frames: int | None = Field(None, ge=1, description="read only the first `frames` frames (None: every image)")


class VamrSource(VamrParams, SourceParams):
    """Where the checkerboard sequence is, and the reader's options."""

    location: ClassVar[tuple[str, ...]] = ("path",)
    path: str = Field(description="the directory holding images/, K.txt, D.txt and poses.txt")

    def layout(self) -> Layout:
        return Layout(
            {
                "first_image": (joined(self.path, "images/img_0001.jpg"),),
                "K": (joined(self.path, "K.txt"),),
                "D": (joined(self.path, "D.txt"),),
                "poses": (joined(self.path, "poses.txt"),),
            }
        )


@with_params(VamrSource)
def read(files: dict, name: str, /, *, params: VamrSource) -> Sequence:
    """The family reader: ``files`` has roles first_image, K, D and poses."""
    directory = Path(files["first_image"]).parent
    present = {p.name for p in directory.glob("img_*.jpg")}
    images = []
    while f"img_{len(images) + 1:04d}.jpg" in present and (params.frames is None or len(images) < params.frames):
        images.append(directory / f"img_{len(images) + 1:04d}.jpg")
    n = len(images)
    K, k_lines = numeric_table(files["K"], 3, "a row of K (3 numbers)")
    if K.shape != (3, 3) or K[2].tolist() != [0, 0, 1] or K[1, 0] != 0 or not (K[0, 0] > 0 and K[1, 1] > 0):
        raise DataFormatError(files["K"], int(k_lines[-1]), "3 rows of an upper-triangular K with K[2] = (0, 0, 1)")
    D, d_lines = numeric_table(files["D"], 2, "k1 k2 (2 numbers)")
    check_finite(str(files["D"]), D, d_lines, "distortion coefficients")
    poses, p_lines = numeric_table(files["poses"], 6, "a pose (wx wy wz tx ty tz)")
    check_finite(str(files["poses"]), poses, p_lines, "poses")
    if len(poses) < n:
        raise DataFormatError(files["poses"], int(p_lines[-1]), f"{n} poses (one per image)", f"{len(poses)} lines")
    # T_cam←world = [R | t]; the Camera's ground truth is its inverse T_world←cam = [Rᵀ | −Rᵀ t]
    R = rodrigues(poses[:n, :3])
    truth = np.tile(np.eye(4), (n, 1, 1))
    truth[:, :3, :3] = R.transpose(0, 2, 1)
    truth[:, :3, 3] = -np.einsum("nji,nj->ni", R, poses[:n, 3:])
    import cv2  # imported on first use: the CLI starts fast

    first = cv2.imread(str(images[0]), cv2.IMREAD_GRAYSCALE)
    if first is None:
        raise DataFormatError(images[0], None, "an image OpenCV can read", "unreadable")
    camera = Camera(
        t=np.arange(n, dtype=float),
        left=np.array([str(p) for p in images], dtype=str),
        K=K,
        distortion=D[0],
        distortion_model="radial_pixels",
        width=first.shape[1],
        height=first.shape[0],
        ground_truth=truth,
    )
    meta = {
        "dataset": "UZH VAMR checkerboard",
        "files": [str(files[r]) for r in ("K", "D", "poses")],
        "images": str(directory),
        "frames": n,
        "pose_lines_unused": int(len(poses) - n),
        "time": "t is the frame index (the sequence has no timestamps)",
        "ground_truth_kind": "poses from the board itself (the course's calibration); stored as T_world<-cam",
        "board": {"inner_corners": [BOARD[0], BOARD[1]], "square_m": BOARD[2]},
    }
    return Sequence(name=name, camera=camera, meta=meta)
