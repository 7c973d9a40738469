"""notebook/2026-11-28-stereo-accuracy.md: stereo VO accuracy on KITTI 00, one subcommand per check of the page.

Run from the repository root, ``python research/scripts/stereo_accuracy.py SUBCOMMAND ARGS``:

``segments SEGMENTS VARIANTS`` (§1): for each ``StereoVOParams`` variant (a JSON list of dicts) and each segment (a
JSON list of ``[first, frames]``), a fresh ``stereo_vo`` run: first, variant, t_rel [%], r_rel [deg/100 m] (segments
of 10, 20, 40, 80 m), end-point drift [% of path], path length ratio (estimate / reference), frames per CPU s, BA
failures. The page's batch: ``segments '[[15,42],[57,43]]' '[{"window":5}, {"window":5,"tracking":{"pnp_threshold":1.0}}]'``.

``speed`` (§4): the reference's speed and acceleration over frames 30–45 and its along-track distance less a cubic in
time over frames 20–60.

``direction ESTIMATE FIRST`` (§2): the median azimuth / elevation [deg] of a VO estimate's displacement over 10 frames,
in its camera i, less the reference's in the reference's camera i; ESTIMATE is an ``estimate.npz`` of a
``slamarena run kitti_vo`` (its ``poses_3d``) whose segment starts at frame FIRST.

``five-point FIRST LAST STEP`` (§2): the same offset for OpenCV's 5-point (``findEssentialMat`` + ``recoverPose``,
3000 ORB features, left images only) over frames i → i + 10 for i in ``range(FIRST, LAST, STEP)``; medians for
i < 90 and i ≥ 100.

``two-frame FIRST LAST STEP [stereo|features]`` (§3): per k in ``range(FIRST, LAST, STEP)``, the step k → k + 2 over
the reference's from PnP on frame k's stereo points (to frame k + 2's stereo points, or with ``features`` to all of its
features, the table's "every k" row with STEP 1) and from a two-keyframe stereo BA (``stereo`` only); medians per 10
frames and on frames < 57 and ≥ 57 (the halves' medians, and the options of this and of ``sgbm``, were added when the
page's heredocs became this script: the page described those variants as edits).

``sgbm FIRST LAST STEP [features|stereo|stereo-ours]`` (§3): the same step from PnP (to all of frame k + 2's features)
on points with OpenCV's SGBM depth at frame k's features, or with ``stereo`` at our stereo points' left pixels, or
with ``stereo-ours`` at the same points (those with an SGBM disparity ≥ 2 px) but with our own disparities; medians
on frames < 57 and ≥ 57.

Each number of the page is a notebook figure (measured at the commit the page states). ``--quick`` runs every
subcommand but ``direction`` (which reads a shipped run's output) at its smallest size (``QUICK``); all of them read
the staged KITTI odometry sequence 00.
"""

from __future__ import annotations

import json
import sys
import time

import cv2
import numpy as np

import slamarena
from slamarena.estimators.vision.features import detect, orb
from slamarena.estimators.vision.matching import match
from slamarena.estimators.vision.pnp import pnp_ransac
from slamarena.estimators.vision.stereo_vo import StereoVOParams, pose_matrix, stereo_points, stereo_vo
from slamarena.estimators.vision.window_ba import Observation, bundle_adjust
from slamarena.experiments.metrics.trajectory3d import end_point_drift, kitti_relative_error, path_length


def _camera(first: int = 0, frames: int = 100):
    return slamarena.load("kitti:00", first=first, frames=frames).camera


def _step(T: np.ndarray, i: int, j: int) -> np.ndarray:
    """Translation of pose j in the frame of pose i (poses 4 × 4, camera to world)."""
    return (np.linalg.inv(T[i]) @ T[j])[:3, 3]


def _azimuth(v: np.ndarray) -> float:
    return np.degrees(np.arctan2(v[0], v[2]))


def _elevation(v: np.ndarray) -> float:
    return np.degrees(np.arctan2(-v[1], v[2]))


def segments(segments_json: str, variants_json: str) -> None:
    for v in json.loads(variants_json):
        for first, n in json.loads(segments_json):
            cam = _camera(first, n)
            start = time.process_time()
            r = stereo_vo(cam, StereoVOParams(**v))
            cpu = time.process_time() - start
            P, Q = r.poses, np.linalg.inv(cam.ground_truth[0]) @ cam.ground_truth
            rel = kitti_relative_error(P, Q, [10, 20, 40, 80], 1)
            print(
                first, v, rel["t_rel_percent"], rel["r_rel_deg_per_100m"], end_point_drift(P, Q)["percent_of_path"],
                path_length(P)[-1] / path_length(Q)[-1], n / cpu, len(r.meta["ba_failures"]), flush=True,
            )  # fmt: skip


def speed() -> None:
    c = _camera()
    s = np.linalg.norm(np.diff(c.ground_truth[:, :3, 3], axis=0), axis=1)
    v = s / np.diff(c.t)
    print("speed 30..45", np.round(v[30:46], 2), "acc", np.round(np.diff(v)[30:45] / np.diff(c.t)[31:46], 2))
    x = np.concatenate([[0], np.cumsum(s)])[20:61]
    t = c.t[20:61]
    print("cubic residual [m]", np.round(x - np.polyval(np.polyfit(t, x, 3), t), 3))


def direction(estimate: str, first: str) -> None:
    P = np.load(estimate)["poses_3d"]
    Q = _camera(int(first), len(P)).ground_truth
    d = [
        (_azimuth(p) - _azimuth(q), _elevation(p) - _elevation(q))
        for p, q in ((_step(P, i, i + 10), _step(Q, i, i + 10)) for i in range(len(P) - 10))
    ]
    print("VO − reference, azimuth / elevation [deg], median:", np.median(d, axis=0))


def five_point(first: str, last: str, step: str) -> None:
    ks = range(int(first), int(last), int(step))
    cam, rows = _camera(0, ks[-1] + 11), []
    for i in ks:
        (u1, d1), (u2, d2) = orb(cam.image(i), 3000), orb(cam.image(i + 10), 3000)
        p, q = match(d1, d2, 0.8, True, 64)
        E, m = cv2.findEssentialMat(u1[p], u2[q], cam.K, cv2.RANSAC, 0.999, 0.5)
        R, t = cv2.recoverPose(E, u1[p], u2[q], cam.K, mask=m)[1:3]
        c, g = (-R.T @ t).ravel(), _step(cam.ground_truth, i, i + 10)
        rows.append((i, _azimuth(c) - _azimuth(g), _elevation(c) - _elevation(g)))
    rows = np.array(rows)
    print(
        "5-point − reference, i < 90:", np.median(rows[rows[:, 0] < 90, 1:], axis=0),
        "i ≥ 100:", np.median(rows[rows[:, 0] >= 100, 1:], axis=0),
    )  # fmt: skip


def two_frame(first: str, last: str, step: str, targets: str = "stereo") -> None:
    ks = range(int(first), int(last), int(step))
    cam, params, rows = _camera(0, max(100, ks[-1] + 3)), StereoVOParams(), []
    Q = cam.ground_truth
    for k in ks:
        ul, ur, X, d = stereo_points(cam, k, params)
        if targets == "stereo":
            vl, vr, _, e = stereo_points(cam, k + 2, params)
        else:  # "features": all of frame k + 2's features; PnP only (the BA needs their right-image columns)
            (vl, e), vr = detect(cam.image(k + 2), params.features), None
        i, j = match(d, e, 0.8, True, 64)
        r = pnp_ransac(cam.K, X[i], vl[j], 1.0, seed=k)
        T, n = pose_matrix(r.R, r.t), np.flatnonzero(r.inliers)
        truth = np.linalg.norm(_step(Q, k, k + 2))
        ba_ratio = np.nan
        if vr is not None:
            obs = [Observation(0, a, *ul[i[m]], ur[i[m]]) for a, m in enumerate(n)]
            obs += [Observation(1, a, *vl[j[m]], vr[j[m]]) for a, m in enumerate(n)]
            ba = bundle_adjust(cam.K, cam.baseline, {0: np.eye(4), 1: T}, X[i][n], obs, (0,), max_iterations=50)
            ba_ratio = np.linalg.norm(ba[0][1][:3, 3]) / truth
        rows.append((k, np.linalg.norm(T[:3, 3]) / truth, ba_ratio))
    rows = np.array(rows)
    print("bin, PnP / two-frame BA step over the reference's (median)")
    for a in range(ks[0], ks[-1] + 1, 10):
        print(a, np.round(np.median(rows[(rows[:, 0] >= a) & (rows[:, 0] < a + 10), 1:], axis=0), 3))
    print(
        "15–56",
        np.round(np.median(rows[rows[:, 0] < 57, 1:], axis=0), 3),
        "57–97",
        np.round(np.median(rows[rows[:, 0] >= 57, 1:], axis=0), 3),
    )


def sgbm(first: str, last: str, step: str, points: str = "features") -> None:
    ks = range(int(first), int(last), int(step))
    cam, params, rows = _camera(0, max(100, ks[-1] + 3)), StereoVOParams(), []
    Q, K = cam.ground_truth, cam.K
    fb = K[0, 0] * cam.baseline
    matcher = cv2.StereoSGBM_create(0, 128, 5, P1=200, P2=800, uniquenessRatio=10, mode=cv2.STEREO_SGBM_MODE_HH)
    for k in ks:
        D = matcher.compute(cam.image(k), cam.image(k, "right")).astype(float) / 16
        if points == "features":  # every left feature
            u, d = detect(cam.image(k), params.features)
        else:  # "stereo", "stereo-ours": our stereo points' left pixels
            u, _, ours, d = stereo_points(cam, k, params)
        disp = D[np.rint(u[:, 1]).astype(int), np.rint(u[:, 0]).astype(int)]
        keep = disp >= 2
        u, d, disp = u[keep], d[keep], disp[keep]
        X = np.column_stack([(u - K[:2, 2]) / np.diag(K)[:2] * (fb / disp)[:, None], fb / disp])
        if points == "stereo-ours":  # the same points with our own disparities (our triangulation)
            X = ours[keep]
        u2, d2 = detect(cam.image(k + 2), params.features)
        i, j = match(d, d2, 0.8, True, 64)
        r = pnp_ransac(K, X[i], u2[j], 1.0, seed=k)
        rows.append((k, np.linalg.norm(r.R.T @ r.t) / np.linalg.norm(_step(Q, k, k + 2))))
    rows = np.array(rows)
    print("15–56", np.median(rows[rows[:, 0] < 57, 1]), "57–97", np.median(rows[rows[:, 0] >= 57, 1]))


COMMANDS = {
    "segments": segments,
    "speed": speed,
    "direction": direction,
    "five-point": five_point,
    "two-frame": two_frame,
    "sgbm": sgbm,
}


def main(argv: list[str]) -> None:
    COMMANDS[argv[0]](*argv[1:])


#: ``--quick``: every subcommand but ``direction`` and each option through every line at its smallest size (one short
#: segment, one frame pair per half; the page's sizes are in its commands).
QUICK = [
    ["segments", "[[57,12]]", '[{"window":5}]'],
    ["speed"],
    ["five-point", "15", "110", "90"],
    ["two-frame", "55", "59", "2"],
    ["two-frame", "55", "59", "2", "features"],
    ["sgbm", "55", "59", "2"],
    ["sgbm", "55", "59", "2", "stereo"],
    ["sgbm", "55", "59", "2", "stereo-ours"],
]

if __name__ == "__main__":
    if sys.argv[1:] == ["--quick"]:
        for argv in QUICK:
            print(*argv, flush=True)
            main(argv)
    else:
        main(sys.argv[1:])
