"""The checkerboard goal with the compiled PnP (EPnP or DLS on the inliers): errors against the staged poses, CPU time.

Run from the repository root: ``python research/scripts/vision_geometry_board.py`` (notebook 2026-11-28-vision-geometry).
"""

from __future__ import annotations

import time

import numpy as np


def main() -> None:
    from slamarena.datasets import load
    from slamarena.datasets.formats.vamr import BOARD, board_corners
    from slamarena.estimators.vision import board_pose
    from slamarena.estimators.vision.lie import rotation_angle

    camera = load("vamr:checkerboard").camera
    truth = np.linalg.inv(camera.ground_truth)
    for nonminimal in ("epnp", "dls"):
        start = time.process_time()
        poses = board_pose.board_poses(camera, board_corners(), BOARD[:2], nonminimal=nonminimal)
        cpu = time.process_time() - start
        centre = -np.einsum("nji,nj->ni", poses.R, poses.t)
        centre_true = -np.einsum("nji,nj->ni", truth[:, :3, :3], truth[:, :3, 3])
        dp = np.linalg.norm(centre - centre_true, axis=1) * 1e3
        da = np.degrees(rotation_angle(np.einsum("nji,njk->nik", poses.R, truth[:, :3, :3])))
        within = poses.found & (dp < 10) & (da < 0.5)
        print(
            f"{nonminimal}: found {poses.found.sum()}/{len(camera)}, within 1 cm / 0.5° {within.sum()}, "
            f"centre error median {np.nanmedian(dp):.2f} max {np.nanmax(dp):.2f} mm, rotation median "
            f"{np.nanmedian(da):.3f} max {np.nanmax(da):.3f} deg, RMS median {np.nanmedian(poses.rms):.3f} px, "
            f"CPU {cpu:.2f} s (detection included)"
        )


if __name__ == "__main__":
    main()
