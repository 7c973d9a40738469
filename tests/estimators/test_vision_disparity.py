"""Sub-pixel disparity: a right image that is the left one shifted by a known non-integer disparity."""

from __future__ import annotations

import cv2
import numpy as np

from slamarena.estimators.vision.disparity import refine_disparity


def shifted_pair(rng, disparity):
    left = cv2.GaussianBlur(rng.integers(0, 256, (120, 200)).astype(np.float32), (0, 0), 1.5)
    left = cv2.normalize(left, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    # right(u) = left(u + d): a point at u_L in the left image is at u_L − d in the right one
    A = np.array([[1.0, 0.0, disparity], [0.0, 1.0, 0.0]])
    right = cv2.warpAffine(left, A, (200, 120), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP)
    return left, right


def test_refined_disparity_recovers_a_subpixel_shift(rng):
    d = 7.3
    left, right = shifted_pair(rng, d)
    u_left = np.column_stack([rng.uniform(30, 170, 50), rng.uniform(20, 100, 50)])
    u_left[:25] = np.rint(u_left[:25])  # level-0 ORB keypoints are integer pixels; higher levels are not
    u_right = np.rint(u_left[:, 0] - d + rng.choice([-2.0, -1.0, 1.0, 2.0], 50))  # off by 1-2 px
    refined, ok = refine_disparity(left, right, u_left, u_right)
    assert ok.mean() > 0.9
    np.testing.assert_allclose(u_left[ok, 0] - refined[ok], d, atol=0.08)
    assert (
        np.median(np.abs(u_left[ok, 0] - refined[ok] - d)) < 0.05
    )  # linear interpolation of a cubic shift: ≈ 0.04 px at a third of a pixel


def test_windows_leaving_the_image_and_minima_at_the_search_end_are_refused(rng):
    left, right = shifted_pair(rng, 4.0)
    u_left = np.array([[3.0, 60.0], [100.0, 2.0], [100.0, 60.0], [100.0, 60.0]])
    u_right = np.array([0.0, 96.0, 96.0, 96.0 + 6])  # the last: the true column 96 lies 6 px off, outside ±5
    refined, ok = refine_disparity(left, right, u_left, u_right)
    assert ok.tolist() == [False, False, True, False] and np.isnan(refined[[0, 1, 3]]).all()
    assert abs(refined[2] - 96.0) < 0.05  # linear interpolation of a cubic shift: ≈ 0.04 px at a third of a pixel
