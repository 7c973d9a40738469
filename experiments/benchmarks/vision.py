"""``slamarena bench vision``: our 5-point and EPnP against OpenCV's on the same real correspondences.

Correspondences come from the staged KITTI 00 frames (``kitti:00``): ORB features (OpenCV) matched by
:func:`~slamarena.estimators.vision.matching.match` (ratio 0.8, mutual check), the same for both sides.

- **Two-view** (frame pairs k → k + 3, k = 0, 4, 8, … < 196; ``--quick``: every 16th): ours
  :func:`~slamarena.estimators.vision.two_view.essential_ransac` (5-point, Sampson threshold 1 px / fx, confidence
  0.999) against ``cv2.findEssentialMat(RANSAC, same threshold, prob 0.999)`` + ``cv2.recoverPose``; the normalised
  8-point algorithm (ours) on our RANSAC's inliers as the baseline. Errors against the ground-truth relative pose:
  rotation angle [deg] and the angle between the translation directions [deg].
- **Minimal solvers**: one 5-point solve on the first 5 inliers of each pair (ours ``five_point`` vs
  ``cv2.findEssentialMat`` on those 5 points) and one P3P solve on the first 3 inliers of each PnP problem (ours
  ``p3p`` vs ``cv2.solveP3P(SOLVEPNP_P3P)``), each repeated 20 × ``repeats`` times.
- **PnP** (stereo frames k = 0, 2, … < 96 → k + 3; ``--quick``: every 8th): 3-D points triangulated at frame k
  (:func:`~slamarena.estimators.vision.stereo_vo.stereo_points`), matched to frame k + 3's left features. The robust
  estimate from all matches: ours :func:`~slamarena.estimators.vision.pnp.pnp_ransac` (P3P, 2 px, LM) vs
  ``cv2.solvePnPRansac(SOLVEPNP_P3P, 2 px, 1000 iterations, confidence 0.999)`` + ``cv2.solvePnP`` refinement
  (``SOLVEPNP_ITERATIVE``, LM, from its pose) on its inliers; the same RANSAC with DLS instead of EPnP on the inliers
  (``nonminimal="dls"``, against the same OpenCV call); then EPnP and DLS alone on the correspondences both RANSACs
  call inliers: ours vs ``cv2.solvePnP(SOLVEPNP_EPNP)`` and vs ``cv2.solvePnP(SOLVEPNP_SQPNP)`` (OpenCV 5 has no
  ``SOLVEPNP_DLS``; SQPnP minimises the same object-space cost globally). (The
  ground-truth pose is not used to pick the clean set: on frames 0–9 the stereo depths are ≈ 22 % shorter than
  the ground-truth motion implies, research/notebook/2026-11-28-vision.md.)

Times are CPU seconds (``time.process_time``) of one process with one BLAS/numba/OpenCV thread, summed over the
problems; each call is repeated (``repeats``) and its minimum kept. The table gives median errors and the speed
ratio ours / OpenCV (> 1: ours slower).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from slamarena.experiments.benchmarks import aim, measure_single_threaded, table, write_rows

#: the staged data it reads (``slamarena bench list``)
STAGED_DATA: dict[str, bool] = {"kitti:00": True}
#: issue 32's speed aim: ours within this factor of OpenCV's C++ (CPU time)
SPEED_AIM = 3.0
#: rows the speed aim does not cover (DLS is benched beside EPnP and P3P; the issue sets no speed for it)
UNAIMED = ("DLS", "P3P RANSAC+DLS")

__all__ = ["main", "measure", "best_cpu"]


def best_cpu(call, repeats: int):
    """(the last result of ``call()``, the least CPU time [s] of ``repeats`` calls)."""
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.process_time()
        result = call()
        best = min(best, time.process_time() - start)
    return result, best


def _angle_deg(R: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0))))


def _direction_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0))))


def _relative(truth: np.ndarray, i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
    """T_j←i = (R, t) from the poses T_world←cam of frames i and j."""
    T = np.linalg.inv(truth[j]) @ truth[i]
    return T[:3, :3], T[:3, 3]


def two_view_rows(camera, pairs, repeats: int) -> list[dict]:
    import cv2

    from slamarena.estimators.vision.features import orb
    from slamarena.estimators.vision.matching import match
    from slamarena.estimators.vision.projection import normalise
    from slamarena.estimators.vision.two_view import eight_point, essential_ransac, five_point, relative_pose

    rows = []
    threshold = 1.0 / camera.K[0, 0]
    for i, j in pairs:
        u1, d1 = orb(camera.image(i))
        u2, d2 = orb(camera.image(j))
        a, b = match(d1, d2)
        x1, x2 = normalise(camera.K, u1[a]), normalise(camera.K, u2[b])
        R_true, t_true = _relative(camera.ground_truth, i, j)
        ours, t_ours = best_cpu(lambda: essential_ransac(x1, x2, threshold, 0.999, 1000, seed=i), repeats)

        def opencv():
            E, mask = cv2.findEssentialMat(x1, x2, np.eye(3), cv2.RANSAC, 0.999, threshold)
            _, R, t, _ = cv2.recoverPose(E[:3], x1, x2, np.eye(3), mask=mask.copy())
            return R, t.ravel(), mask.ravel().astype(bool)

        (R_cv, t_cv, inliers_cv), t_opencv = best_cpu(opencv, repeats)
        inl = ours.inliers
        E8 = eight_point(x1[inl], x2[inl])
        R8, t8, _ = relative_pose(E8, x1[inl], x2[inl])
        five = np.flatnonzero(inl)[:5]
        _, t_five = best_cpu(lambda: five_point(x1[five], x2[five]), repeats * 20)
        _, t_five_cv = best_cpu(
            lambda: cv2.findEssentialMat(x1[five], x2[five], np.eye(3), cv2.RANSAC, 0.999, threshold), repeats * 20
        )
        rows.append(
            {
                "pair": f"{i}-{j}",
                "matches": int(len(a)),
                "inliers_ours": int(inl.sum()),
                "inliers_opencv": int(inliers_cv.sum()),
                "rot_deg_ours": _angle_deg(ours.R.T @ R_true),
                "rot_deg_opencv": _angle_deg(R_cv.T @ R_true),
                "rot_deg_8pt": _angle_deg(R8.T @ R_true),
                "dir_deg_ours": _direction_deg(ours.t, t_true),
                "dir_deg_opencv": _direction_deg(t_cv, t_true),
                "dir_deg_8pt": _direction_deg(t8, t_true),
                "cpu_ours": t_ours,
                "cpu_opencv": t_opencv,
                "cpu_5pt_ours": t_five,
                "cpu_5pt_opencv": t_five_cv,
            }
        )
    return rows


def pnp_rows(camera, frames, repeats: int) -> list[dict]:
    import cv2

    from slamarena.estimators.vision.dls import dls
    from slamarena.estimators.vision.features import orb
    from slamarena.estimators.vision.matching import match
    from slamarena.estimators.vision.pnp import epnp, p3p, pnp_ransac
    from slamarena.estimators.vision.projection import normalise
    from slamarena.estimators.vision.stereo_vo import StereoVOParams, stereo_points

    rows = []
    for i in frames:
        j = i + 3
        _, _, X, d = stereo_points(camera, i, StereoVOParams())
        u, e = orb(camera.image(j))
        a, b = match(d, e)
        X, u = X[a], u[b]
        R_true, t_true = _relative(camera.ground_truth, i, j)
        ours, t_ours = best_cpu(lambda: pnp_ransac(camera.K, X, u, 2.0, "p3p", 0.999, 1000, seed=i), repeats)
        ours_dls, t_ours_dls = best_cpu(
            lambda: pnp_ransac(camera.K, X, u, 2.0, "p3p", 0.999, 1000, seed=i, nonminimal="dls"), repeats
        )

        def opencv():
            _, r, t, inl = cv2.solvePnPRansac(
                X, u, camera.K, None, iterationsCount=1000, reprojectionError=2.0, confidence=0.999,
                flags=cv2.SOLVEPNP_P3P,
            )  # fmt: skip
            inl = inl.ravel()
            _, r, t = cv2.solvePnP(X[inl], u[inl], camera.K, None, r, t, True, cv2.SOLVEPNP_ITERATIVE)
            return cv2.Rodrigues(r)[0], t.ravel(), inl

        (R_cv, t_cv, inl_cv), t_opencv = best_cpu(opencv, repeats)
        clean = ours.inliers.copy()
        clean[np.setdiff1d(np.arange(len(X)), inl_cv)] = False  # inliers of both RANSACs
        Xc, uc = X[clean], u[clean]
        (R_e, t_e), t_epnp = best_cpu(lambda: epnp(Xc, normalise(camera.K, uc)), repeats)
        (_, rv, tv), t_epnp_cv = best_cpu(
            lambda: cv2.solvePnP(Xc, uc, camera.K, None, flags=cv2.SOLVEPNP_EPNP), repeats
        )
        (R_d, t_d), t_dls = best_cpu(lambda: dls(Xc, normalise(camera.K, uc)), repeats)
        (_, rs, ts), t_sqpnp = best_cpu(lambda: cv2.solvePnP(Xc, uc, camera.K, None, flags=cv2.SOLVEPNP_SQPNP), repeats)
        x3, u3 = normalise(camera.K, uc[:3]), uc[:3]
        _, t_p3p = best_cpu(lambda: p3p(Xc[:3], x3), repeats * 20)
        _, t_p3p_cv = best_cpu(lambda: cv2.solveP3P(Xc[:3], u3, camera.K, None, flags=cv2.SOLVEPNP_P3P), repeats * 20)
        rows.append(
            {
                "frames": f"{i}-{j}",
                "matches": int(len(a)),
                "clean": int(clean.sum()),
                "epnp_rot_deg_ours": _angle_deg(R_e.T @ R_true),
                "epnp_rot_deg_opencv": _angle_deg(cv2.Rodrigues(rv)[0].T @ R_true),
                "epnp_trans_m_ours": float(np.linalg.norm(t_e - t_true)),
                "epnp_trans_m_opencv": float(np.linalg.norm(tv.ravel() - t_true)),
                "dls_rot_deg_ours": _angle_deg(R_d.T @ R_true),
                "dls_rot_deg_opencv": _angle_deg(cv2.Rodrigues(rs)[0].T @ R_true),
                "dls_trans_m_ours": float(np.linalg.norm(t_d - t_true)),
                "dls_trans_m_opencv": float(np.linalg.norm(ts.ravel() - t_true)),
                "ransac_dls_rot_deg_ours": _angle_deg(ours_dls.R.T @ R_true),
                "ransac_dls_trans_m_ours": float(np.linalg.norm(ours_dls.t - t_true)),
                "ransac_rot_deg_ours": _angle_deg(ours.R.T @ R_true),
                "ransac_rot_deg_opencv": _angle_deg(R_cv.T @ R_true),
                "ransac_trans_m_ours": float(np.linalg.norm(ours.t - t_true)),
                "ransac_trans_m_opencv": float(np.linalg.norm(t_cv - t_true)),
                "inliers_ours": int(ours.inliers.sum()),
                "inliers_opencv": int(len(inl_cv)),
                "cpu_epnp_ours": t_epnp,
                "cpu_epnp_opencv": t_epnp_cv,
                "cpu_dls_ours": t_dls,
                "cpu_sqpnp_opencv": t_sqpnp,
                "cpu_p3p_ours": t_p3p,
                "cpu_p3p_opencv": t_p3p_cv,
                "cpu_ransac_dls_ours": t_ours_dls,
                "cpu_ransac_ours": t_ours,
                "cpu_ransac_opencv": t_opencv,
            }
        )
    return rows


def measure(quick: bool = False, repeats: int = 3) -> dict:
    """Both tables as lists of rows (run in a single-threaded child by :func:`main`)."""
    import cv2

    from slamarena.datasets import load

    cv2.setNumThreads(1)
    camera = load("kitti:00").camera
    pairs = [(k, k + 3) for k in range(0, 196, 16 if quick else 4)]
    stereo = camera.select(slice(0, 100))
    frames = list(range(0, 96, 8 if quick else 2))
    two_view_rows(camera, pairs[:1], 1)  # untimed: numba compilation, OpenCV's first calls
    pnp_rows(stereo, frames[:1], 1)
    return {"two_view": two_view_rows(camera, pairs, repeats), "pnp": pnp_rows(stereo, frames, repeats)}


def summary(result: dict) -> list[dict]:
    """One row per comparison: median errors of ours and OpenCV's, and the CPU-time ratio ours / OpenCV."""
    tv, pn = result["two_view"], result["pnp"]

    def med(rows, key):
        return float(np.median([r[key] for r in rows]))

    def ratio(rows, ours, theirs):
        return sum(r[ours] for r in rows) / sum(r[theirs] for r in rows)

    # comparison, table, key of ours, key of OpenCV's, key of the 8-point baseline, CPU keys (ours, OpenCV's)
    spec = [
        ("5-point RANSAC: rotation [deg]", tv, "rot_deg_ours", "rot_deg_opencv", "rot_deg_8pt", ("cpu_ours", "cpu_opencv")),
        ("5-point RANSAC: translation direction [deg]", tv, "dir_deg_ours", "dir_deg_opencv", "dir_deg_8pt", None),
        ("5-point minimal solve", tv, None, None, None, ("cpu_5pt_ours", "cpu_5pt_opencv")),
        ("EPnP (clean set): rotation [deg]", pn, "epnp_rot_deg_ours", "epnp_rot_deg_opencv", None, ("cpu_epnp_ours", "cpu_epnp_opencv")),
        ("EPnP (clean set): translation [m]", pn, "epnp_trans_m_ours", "epnp_trans_m_opencv", None, None),
        ("P3P RANSAC+LM: rotation [deg]", pn, "ransac_rot_deg_ours", "ransac_rot_deg_opencv", None,
         ("cpu_ransac_ours", "cpu_ransac_opencv")),
        ("P3P RANSAC+LM: translation [m]", pn, "ransac_trans_m_ours", "ransac_trans_m_opencv", None, None),
        ("P3P minimal solve", pn, None, None, None, ("cpu_p3p_ours", "cpu_p3p_opencv")),
        ("DLS vs SQPnP (clean set): rotation [deg]", pn, "dls_rot_deg_ours", "dls_rot_deg_opencv", None,
         ("cpu_dls_ours", "cpu_sqpnp_opencv")),
        ("DLS vs SQPnP (clean set): translation [m]", pn, "dls_trans_m_ours", "dls_trans_m_opencv", None, None),
        ("P3P RANSAC+DLS+LM: rotation [deg]", pn, "ransac_dls_rot_deg_ours", "ransac_rot_deg_opencv", None,
         ("cpu_ransac_dls_ours", "cpu_ransac_opencv")),
        ("P3P RANSAC+DLS+LM: translation [m]", pn, "ransac_dls_trans_m_ours", "ransac_trans_m_opencv", None, None),
    ]  # fmt: skip
    return [
        {
            "comparison": name,
            "ours": med(rows, ours) if ours else None,
            "opencv": med(rows, theirs) if theirs else None,
            "8-point": med(rows, eight) if eight else None,
            "cpu_ratio": ratio(rows, *cpu) if cpu else None,
        }
        for name, rows, ours, theirs, eight, cpu in spec
    ]


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    result = measure_single_threaded("slamarena.experiments.benchmarks.vision", quick=quick)
    rows = summary(result)
    shown = table(
        f"ours vs OpenCV on KITTI 00 ({len(result['two_view'])} frame pairs, {len(result['pnp'])} PnP problems)",
        ("comparison", "ours", "opencv", "8-point", "cpu_ratio"),
    )
    for row in rows:
        shown.add_row(*[f"{v:.4g}" if isinstance(v, float) else str(v if v is not None else "") for v in row.values()])
    console = Console()
    console.print(shown)
    for row in rows:
        if row["cpu_ratio"] is not None and not row["comparison"].startswith(UNAIMED):
            met = row["cpu_ratio"] <= SPEED_AIM
            console.print(
                f"{row['comparison']}: ours / OpenCV CPU {row['cpu_ratio']:.3g}x {aim(f'<= {SPEED_AIM:g}x', met)}"
            )
    write_rows(result["two_view"], out, "vision_two_view.csv")
    write_rows(result["pnp"], out, "vision_pnp.csv")
    write_rows(rows, out, "vision_summary.csv")
    return 0


if __name__ == "__main__":
    print(json.dumps(measure(**json.loads(sys.argv[1]))))
