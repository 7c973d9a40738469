"""``slamarena bench scan-matching``: scans matched per second per matcher, and the whole Intel
log mapped by the Gauss-Newton pipeline as a real-time factor.

1. Matchers. Scan k of the SLAM-corrected Intel log is matched against the scans k−4 … k−1
   at their corrected poses (grid matchers: a fresh two-level map pyramid, so the correlative
   matchers also pay for their likelihood grid, as after every map update in SLAM; point
   matchers: the same scans' end points), from the corrected pose of k plus a random offset
   (σ = 5 cm, 2°). Reported: scans matched per second (the match call only; once right after the
   map was built, once more on the same map — the correlative matchers cache their likelihood
   grid and max-pyramid per map version, as between map updates in SLAM), and the median
   and 90th percentile of the translational and rotational difference to the corrected pose —
   a reference (another SLAM system's result), not ground truth. Throughputs are also given
   as ratios to the Gauss-Newton matcher measured in the same run.
2. Pipeline. ``GridSLAM()`` (Gauss-Newton, defaults) over the raw Intel log (13,631 scans,
   2,691 s): wall time of the scan loop and the real-time factor = log duration / wall time
   (aim ≥ 20 on one core). ``--quick``: the first 2,000 scans.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from slamarena.datasets.geometry import between, transform_points
from slamarena.experiments.benchmarks import aim, table, write_rows
from slamarena.mapping.map_pyramid import MapPyramid
from slamarena.mapping.scan_matching import make_matcher

STAGED_DATA: dict[str, bool] = {"carmen-corrected:intel": True, "carmen:intel": True}
AIM_REAL_TIME = 20.0
MATCHERS = [  # (label, registry name, parameters)
    ("gauss_newton", "gauss_newton", {}),
    ("gauss_newton hector_gradient_bug", "gauss_newton", {"hector_gradient_bug": True}),
    (
        "gauss_newton without prior (pure Hector)",
        "gauss_newton",
        {"prior_translation_weight": 0.0, "prior_rotation_weight": 0.0},
    ),
    ("correlative (exhaustive)", "correlative", {}),
    ("branch_and_bound", "branch_and_bound", {}),
    ("kiss_icp", "kiss_icp", {}),
    ("open3d point-to-point", "open3d_icp", {"method": "point_to_point"}),
    ("open3d point-to-plane", "open3d_icp", {"method": "point_to_plane"}),
    ("open3d generalized ICP", "open3d_icp", {"method": "generalized"}),
]


def _points(sc, k):
    r, a = sc.beams(k)
    ok = np.isfinite(r) & (r > 0) & (r < sc.max_range)
    return transform_points(sc.mount, np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])]))


def matcher_table(sc, ks, seed: int = 0) -> list[dict]:
    rng = np.random.default_rng(seed)
    offsets = rng.standard_normal((len(ks), 3)) * [0.05, 0.05, np.radians(2.0)]
    rows = []
    for label, name, params in MATCHERS:
        m = make_matcher(name, **params)
        errs, spent, again = [], 0.0, 0.0
        for i, (k, off) in enumerate(zip(ks, offsets)):
            before = range(k - 4, k)
            if m.kind == "grid":
                ref = MapPyramid(resolution=0.05, levels=2, size=40.0)
                for j in before:
                    ref.integrate(*sc.beams(j), sc.pose[j], sc.mount, max_range=sc.max_range, clear_range=5.0)
            else:
                ref = np.concatenate([transform_points(sc.pose[j], _points(sc, j)) for j in before])
            pts = _points(sc, k)
            if i == 0:  # untimed: imports, compiled-kernel loading
                m.match(ref, pts, sc.pose[k] + off)
            t = time.perf_counter()
            res = m.match(ref, pts, sc.pose[k] + off)
            spent += time.perf_counter() - t
            t = time.perf_counter()
            m.match(ref, pts, sc.pose[k] + off)  # the same map again: what a scan between map updates costs
            again += time.perf_counter() - t
            e = between(sc.pose[k], res.pose)
            errs.append([np.hypot(e[0], e[1]), abs(e[2])])
        errs = np.array(errs)
        rows.append(
            {
                "matcher": label,
                "scans_per_s": len(ks) / spent,
                "scans_per_s_same_map": len(ks) / again,
                "trans_median": float(np.median(errs[:, 0])),
                "trans_p90": float(np.percentile(errs[:, 0], 90)),
                "rot_median": float(np.median(errs[:, 1])),
                "rot_p90": float(np.percentile(errs[:, 1], 90)),
            }
        )
    return rows


def pipeline(seq, limit: int | None):
    from slamarena.mapping.grid_slam import GridSLAM

    if limit is not None:
        seq = type(seq)(name=seq.name, scans=seq.scans.select(slice(0, limit)))
    warm = type(seq)(name="warm-up", scans=seq.scans.select(slice(0, 30)))
    GridSLAM().run(warm)  # load the compiled numba kernels before timing
    slam = GridSLAM()
    t = time.perf_counter()
    est = slam.run(seq)
    wall = time.perf_counter() - t
    duration = float(seq.scans.t[-1] - seq.scans.t[0])
    return (
        {
            "scans": len(seq.scans),
            "duration_s": duration,
            "wall_s": wall,
            "real_time_factor": duration / wall,
            "ms_per_scan_median": 1e3 * float(np.median(est.step_time)),
            "ms_per_scan_p99": 1e3 * float(np.percentile(est.step_time, 99)),
            "map_update_share": float(est.step_time[est.diagnostics["map_updated"]].sum() / est.step_time.sum()),
            "map_updates": est.meta["map_updates"],
        },
        slam,
        est,
    )


def main(out: Path | None = None, quick: bool = False) -> int:
    from rich.console import Console

    from slamarena import datasets

    console = Console(width=150)
    corrected = datasets.load("carmen-corrected:intel").scans
    ks = np.arange(50, len(corrected.t), 40 if quick else 8)
    rows = matcher_table(corrected, ks)
    gn = rows[0]["scans_per_s_same_map"]
    matchers = table(
        f"scan matchers on carmen-corrected:intel ({len(ks)} scans vs the 4 before, offset σ 5 cm / 2°)",
        (
            "matcher",
            "scans / s (new map)",
            "scans / s (same map)",
            "vs gauss_newton",
            "trans. median [m]",
            "trans. p90 [m]",
            "rot. median [°]",
            "rot. p90 [°]",
        ),
    )
    for r in rows:
        matchers.add_row(
            r["matcher"],
            f"{r['scans_per_s']:.0f}",
            f"{r['scans_per_s_same_map']:.0f}",
            f"{r['scans_per_s_same_map'] / gn:.3f}",
            f"{r['trans_median']:.3f}",
            f"{r['trans_p90']:.3f}",
            f"{np.degrees(r['rot_median']):.2f}",
            f"{np.degrees(r['rot_p90']):.2f}",
        )
    console.print(matchers)

    intel = datasets.load("carmen:intel")
    p, slam, est = pipeline(intel, 2000 if quick else None)
    console.print(
        f"GridSLAM (gauss_newton) on carmen:intel: {p['scans']} scans, {p['duration_s']:.0f} s of log in {p['wall_s']:.1f} s → "
        f"{p['real_time_factor']:.1f}× faster than real time {aim(f'≥ {AIM_REAL_TIME:g}×', p['real_time_factor'] >= AIM_REAL_TIME)}; "
        f"{p['ms_per_scan_median']:.2f} ms/scan median, "
        f"{p['ms_per_scan_p99']:.1f} ms p99; {p['map_updates']} map updates take {100 * p['map_update_share']:.0f} % of the time",
        markup=False,
    )
    if write_rows(rows, out, "scan_matching.csv") is not None:
        import json

        (Path(out) / "intel_pipeline.json").write_text(json.dumps(p, indent=2))
        slam.map.save_png(out / "intel_map.png")
    return 0
