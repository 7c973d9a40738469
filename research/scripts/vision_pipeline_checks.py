"""notebook/2026-11-28-vision-pipeline.md: where the stereo VO error comes from, checked on KITTI 00.

Run from the repository root (one process; CPU time of this process):

- ``python research/scripts/vision_pipeline_checks.py run stereo FIRST FRAMES '{"window": 5}'`` (or ``mono``): one
  pipeline (StereoVOParams / MonoVOParams' defaults, overridden by the JSON) on ``kitti:00`` from frame FIRST:
  t_rel / r_rel over 10, 20, 40, 80 m from every frame, end-point drift (stereo) or the ATE after Sim(3) (mono),
  keyframes, lost frames, frames per CPU second; then the step ratio VO / ground truth (median per 10 frames) and
  the yaw and pitch error every 10 frames.
- ``... rotation``: the rotation between left frames a → b by OpenCV's 5-point RANSAC (no stereo, no map: an
  independent estimate) against the ground truth's and the stereo VO's (window 5), on frames 0–39.
- ``... steps``: per 10 frames of 0–99, the distance travelled by the stereo VO (window 5) and by the monocular VO
  (window 10, its scale fitted to the ground truth on frames 15–99), each over the ground truth's.
- ``... depth``: the scale of PnP from frame k's stereo points to frame k + 2 (k = 15, 18, …, 96) with the near
  (z < 12 m), middle (12–25 m) and far (> 25 m) points apart, over the ground-truth step: a disparity bias δ shows
  as a scale error −δ / d growing with the depth.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np


def _load(first: int, frames: int):
    import slamarena

    return slamarena.load("kitti:00", first=first, frames=frames).camera


def _yaw_pitch(R: np.ndarray) -> tuple[float, float]:
    return float(np.degrees(np.arctan2(R[0, 2], R[2, 2]))), float(np.degrees(np.arcsin(-R[1, 2])))


def run(kind: str, first: int, frames: int, overrides: dict) -> None:
    from slamarena.estimators.vision.mono_vo import MonoVOParams, mono_vo
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_vo
    from slamarena.experiments.metrics.trajectory3d import ate_3d, end_point_drift, kitti_relative_error

    camera = _load(first, frames)
    start = time.process_time()
    if kind == "stereo":
        result = stereo_vo(camera, StereoVOParams(**overrides))
    else:
        result = mono_vo(camera, MonoVOParams(**overrides))
    cpu = time.process_time() - start
    P, Q = result.poses, np.linalg.inv(camera.ground_truth[0]) @ camera.ground_truth
    rel = kitti_relative_error(P, Q, [10, 20, 40, 80], 1)
    score = (
        f"drift {end_point_drift(P, Q)['percent_of_path']:.2f} %"
        if kind == "stereo"
        else f"ATE Sim(3) {ate_3d(P, Q, 'sim3')['rmse_percent_of_path']:.2f} %"
    )
    print(
        f"{kind} frames {first}–{first + frames - 1} {overrides}: t_rel {rel['t_rel_percent']:.2f} %, r_rel "
        f"{rel['r_rel_deg_per_100m']:.2f} deg/100 m, {score}, {len(result.keyframes)} keyframes, {result.lost} lost, "
        f"{frames / cpu:.1f} frames per CPU s, BA runs {result.meta.get('ba_runs')}, "
        f"failures {len(result.meta.get('ba_failures', []))}"
    )
    per = {L: round(v["t_rel_percent"], 2) for L, v in rel["per_length"].items() if v["t_rel_percent"] is not None}
    print("t_rel per length:", per)
    step = lambda T: np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)  # noqa: E731
    ratio = step(P) / step(Q)
    print(
        "step ratio per 10 frames:", [round(float(np.median(ratio[i : i + 10])), 3) for i in range(0, len(ratio), 10)]
    )
    errors = [np.subtract(_yaw_pitch(P[i, :3, :3]), _yaw_pitch(Q[i, :3, :3])) for i in range(0, len(P), 10)]
    print("yaw error every 10 frames [deg]:", [round(float(e[0]), 2) for e in errors])
    print("pitch error every 10 frames [deg]:", [round(float(e[1]), 2) for e in errors])


def rotation() -> None:
    import cv2

    from slamarena.estimators.vision.features import orb
    from slamarena.estimators.vision.matching import match
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_vo

    camera = _load(0, 40)
    Q, P = camera.ground_truth, stereo_vo(camera, StereoVOParams(window=5)).poses

    def angle(R):
        return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))

    print("a → b: rotation vectors [deg] 5-point | ground truth | stereo VO; angle 5-point vs ground truth, vs VO")
    for a, b in [(0, 5), (5, 10), (0, 10), (10, 15), (0, 15), (15, 20), (20, 30), (30, 39)]:
        ua, da = orb(camera.image(a), 3000)
        ub, db = orb(camera.image(b), 3000)
        i, j = match(da, db, 0.8, True, 64)
        E, mask = cv2.findEssentialMat(ua[i], ub[j], camera.K, cv2.RANSAC, 0.999, 0.5)
        _, R, _, _ = cv2.recoverPose(E, ua[i], ub[j], camera.K, mask=mask)
        Rq, Rp = ((np.linalg.inv(T[b]) @ T[a])[:3, :3] for T in (Q, P))
        vec = [np.degrees(cv2.Rodrigues(x)[0].ravel()).round(2).tolist() for x in (R, Rq, Rp)]
        print(a, b, *vec, round(angle(R @ Rq.T), 2), round(angle(R @ Rp.T), 2))


def steps() -> None:
    from slamarena.estimators.vision.mono_vo import MonoVOParams, mono_vo
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_vo

    S = stereo_vo(_load(0, 100), StereoVOParams(window=5)).poses
    camera = _load(0, 200)
    M, Q = mono_vo(camera, MonoVOParams(window=10)).poses[:100], camera.ground_truth[:100]
    step = lambda T: np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)  # noqa: E731
    q, s, m = step(Q), step(S), step(M)
    m = m * q[15:].sum() / m[15:].sum()
    print("frames, ground truth [m], stereo / truth, mono / truth, stereo / mono")
    for a in range(0, 99, 10):
        b = min(a + 10, 99)
        print(
            a, b, round(q[a:b].sum(), 2), *(round(x[a:b].sum() / y[a:b].sum(), 3) for x, y in ((s, q), (m, q), (s, m)))
        )


def depth() -> None:
    from slamarena.estimators.vision.features import detect
    from slamarena.estimators.vision.matching import match
    from slamarena.estimators.vision.pnp import pnp_ransac
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_points

    camera, params = _load(0, 100), StereoVOParams()
    Q, rows = camera.ground_truth, []
    for k in range(15, 97, 3):
        _, _, X, d = stereo_points(camera, k, params)
        u2, d2 = detect(camera.image(k + 2), params.features)
        i, j = match(d, d2, 0.8, True, 64)
        truth = np.linalg.norm((np.linalg.inv(Q[k]) @ Q[k + 2])[:3, 3])
        row = [k]
        for low, high in [(0, 12), (12, 25), (25, np.inf), (0, np.inf)]:
            near = (X[i, 2] >= low) & (X[i, 2] < high)
            try:
                result = pnp_ransac(camera.K, X[i][near], u2[j][near], 1.0, seed=k)
                row.append(np.linalg.norm(result.t) / truth if result.inliers.sum() > 20 else np.nan)
            except ValueError:
                row.append(np.nan)
        rows.append(row)
    rows = np.array(rows)
    print("k, PnP step / ground-truth step with points z < 12 m, 12–25 m, > 25 m, all")
    print(np.array2string(rows, precision=3, suppress_small=True))
    print(
        "medians:", np.round(np.nanmedian(rows[:, 1:], axis=0), 4), "frames:", np.sum(np.isfinite(rows[:, 1:]), axis=0)
    )


def main(argv: list[str]) -> None:
    command, *args = argv
    if command == "run":
        run(args[0], int(args[1]), int(args[2]), json.loads(args[3]) if len(args) > 3 else {})
    else:
        {"rotation": rotation, "steps": steps, "depth": depth}[command]()


if __name__ == "__main__":
    main(sys.argv[1:])
