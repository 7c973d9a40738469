"""notebook/2026-11-21-grid-slam-results.md: the tables of GridSLAM on sim:laser and on the raw CARMEN logs.

Run from the repository root: ``python research/scripts/mapping_studies.py STUDY`` with STUDY one of ``sim``
(sim:laser, seeds 0–4: ATE after SE(2) alignment and the map against the true walls moved by the same alignment, IoU
and precision / recall within one cell, for GridSLAM with each matcher), ``carmen`` (every staged raw CARMEN log with
the Gauss-Newton pipeline: time and real-time factor, and where a SLAM-corrected version of the log exists the
relative-pose agreement with it — a reference comparison, the corrected poses being another SLAM system's output: the
corrected log's scans are found in the raw log by their identical readings, and the relations (i, i+1) and (i, i+10)
between corrected scans are scored with the relation metric) or ``interlaced`` (fr-clinic with all four interlaced
layouts against its 181-beam layout alone). Each writes ``results/mapping_study/{sim,carmen,fr_clinic_interlaced}.json``
and the map images there, and prints its rows (minutes to an hour on a loaded machine).

Moved from the slow tests of ``tests/mapping/test_mapping_study.py`` (issue 34), the same code without the assertions:
the ATE columns of ``sim`` are the shipped config ``grid_slam_matchers`` (its claims are the findings), and the test
file pins the findings at one seed.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from slamarena.datasets.geometry import between, inverse
from slamarena.mapping.evaluation import occupancy_agreement, true_occupancy_on
from slamarena.mapping.grid_slam import GridSLAM

OUT = Path("results/mapping_study")
RAW_TO_CORRECTED = {"intel": "intel", "fr079": "freiburg-079", "aces": "aces", "mit-csail": "csail", "fr-clinic": None}
SIM_MATCHERS = {
    "gauss_newton": {},
    "gauss_newton (pure Hector)": {"matcher_params": {"prior_translation_weight": 0.0, "prior_rotation_weight": 0.0}},
    "gauss_newton (hector_gradient_bug)": {"matcher_params": {"hector_gradient_bug": True}},
    "branch_and_bound": {"matcher": "branch_and_bound"},
    "kiss_icp": {"matcher": "kiss_icp"},
    "open3d_icp (generalized)": {"matcher": "open3d_icp", "matcher_params": {"method": "generalized"}},
}


def _aligned(est, seq):
    from slamarena.experiments.metrics.alignment import fit_alignment
    from slamarena.experiments.metrics.reference import associate, reference_of
    from slamarena.experiments.metrics.trajectory import ATEParams, ate

    stats, _ = ate(est, reference_of(seq), ATEParams())
    match = associate(reference_of(seq), est.t, 0.1)
    A = fit_alignment(est.poses[match.index, :2], match.gt[:, :2], "se2")
    return stats, inverse(np.array([*A.translation, A.angle]))


def study_sim():
    from slamarena.datasets.sim.laser import simulate

    OUT.mkdir(parents=True, exist_ok=True)
    results = {}
    for label, kw in SIM_MATCHERS.items():
        rows = []
        for seed in range(5):
            seq = simulate(seed=seed)
            slam = GridSLAM(frontend=kw)
            est = slam.run(seq)
            stats, truth_in_map = _aligned(est, seq)
            agreement = occupancy_agreement(slam.map, true_occupancy_on(slam.map, "loop", truth_in_map))
            rows.append(
                {
                    "seed": seed,
                    "ate_rmse": stats["rmse"],
                    "ate_max": stats["max"],
                    "heading_rmse": stats["heading_rmse"],
                    "iou": agreement["iou"],
                    "precision": agreement["precision"],
                    "recall": agreement["recall"],
                    "ms_per_scan": 1e3 * float(np.mean(est.step_time)),
                }
            )
            if seed == 0:
                slam.map.save_png(
                    OUT
                    / f"sim_{label.split()[0]}{'_' + label.split('(')[1][:-1].replace(' ', '_') if '(' in label else ''}.png"
                )
        results[label] = rows
        print(label, {k: round(float(np.median([r[k] for r in rows])), 4) for k in rows[0] if k != "seed"})
    odo = []
    for seed in range(5):
        from slamarena.datasets.estimate import Estimate

        seq = simulate(seed=seed)
        odo.append(_aligned(Estimate("odometry", seq.scans.t, seq.scans.pose), seq)[0]["rmse"])
    results["odometry"] = [{"seed": s, "ate_rmse": v} for s, v in enumerate(odo)]
    print("odometry ATE", np.round(odo, 3))
    (OUT / "sim.json").write_text(json.dumps(results, indent=2))


def _match_scans(raw, corrected):
    """Index of each corrected scan in the raw log (identical readings), −1 if absent."""
    key = lambda r: [row.tobytes() for row in np.round(np.asarray(r, float) * 100).astype(np.int32)]
    where = {}
    for k, b in enumerate(key(raw.ranges)):
        where.setdefault(b, k)
    return np.array([where.get(b, -1) for b in key(corrected.ranges)])


def study_carmen():
    for raw_name in RAW_TO_CORRECTED:
        _carmen(raw_name)


def _carmen(raw_name):
    import time

    from slamarena import datasets
    from slamarena.datasets.errors import DatasetNotFoundError
    from slamarena.experiments.metrics.relations import RelationsParams, relation_error

    try:
        seq = datasets.load(f"carmen:{raw_name}")
    except DatasetNotFoundError as exc:
        print(f"skipped: {exc}")
        return
    OUT.mkdir(parents=True, exist_ok=True)
    slam = GridSLAM()
    t = time.perf_counter()
    est = slam.run(seq)
    wall = time.perf_counter() - t
    slam.map.save_png(OUT / f"carmen_{raw_name}.png")
    duration = float(seq.scans.t[-1] - seq.scans.t[0])
    row = {
        "log": raw_name,
        "scans": len(seq.scans),
        "duration_s": duration,
        "wall_s": wall,
        "real_time_factor": duration / wall,
        "bad_beams": est.meta["bad_beams"],
        "scans_not_matched": est.meta["scans_not_matched"],
        "map_updates": est.meta["map_updates"],
        "map_shape": est.meta["map_shape"],
    }
    odometry = type(est)("odometry", seq.scans.t, seq.scans.pose)
    corrected_name = RAW_TO_CORRECTED[raw_name]
    if corrected_name is not None:
        ref = datasets.load(f"carmen-corrected:{corrected_name}").scans
        idx = _match_scans(seq.scans, ref)
        found = idx >= 0
        row["corrected_scans"], row["corrected_scans_found"] = int(len(idx)), int(found.sum())
        for gap in (1, 10):
            i = np.flatnonzero(found[:-gap] & found[gap:])
            t_i, t_j = seq.scans.t[idx[i]], seq.scans.t[idx[i + gap]]
            delta = between(ref.pose[i], ref.pose[i + gap])
            for label, e in (("slam", est), ("odometry", odometry)):
                stats, _ = relation_error(e, t_i, t_j, delta, RelationsParams(tolerance=1e-6))
                row[f"relations_{gap}_{label}"] = stats
        print(
            raw_name,
            {
                k: (round(v["trans_mean"], 4), round(v["rot_mean"], 4))
                for k, v in row.items()
                if k.startswith("relations")
            },
        )
    print(raw_name, {k: v for k, v in row.items() if not k.startswith("relations")})
    path = OUT / "carmen.json"
    table = json.loads(path.read_text()) if path.exists() else {}
    table[raw_name] = row
    path.write_text(json.dumps(table, indent=2))


def study_interlaced():
    for first in (500, 2000, None):
        _fr_clinic_interlaced(first)


def _fr_clinic_interlaced(first):
    """fr-clinic with all four interlaced layouts in one stream against its 181-beam layout alone,
    over the same stretch of the log (the first ``first`` scans of the full stream; None: all).
    No reference exists: map sharpness, matcher score, the end points of the shared 181-beam scans
    on the final map, the wall-orientation concentration (rectilinear building: heading drift bends
    the corridors), and the difference of the two trajectories at the shared scans."""
    from slamarena import datasets
    from slamarena.datasets.errors import DatasetNotFoundError
    from slamarena.mapping.evaluation import hits_on_occupied, map_sharpness, wall_orientation_concentration

    try:
        everything = datasets.load("carmen:fr-clinic").scans
        single = datasets.load("carmen:fr-clinic", interlaced=False).scans
    except DatasetNotFoundError as exc:
        print(f"skipped: {exc}")
        return
    OUT.mkdir(parents=True, exist_ok=True)
    stretch = everything.select(slice(0, first))
    single = single.select(single.t <= stretch.t[-1])
    shared = np.flatnonzero(stretch.beam_count == stretch.ranges.shape[1])  # the 181-beam scans: in both runs
    assert np.array_equal(stretch.t[shared], single.t)
    rows, shared_poses = {}, {}
    for label, scans, common in (
        ("all layouts", stretch, shared),
        ("181-beam layout only", single, np.arange(len(single))),
    ):
        from slamarena.datasets.sequence import Sequence

        slam = GridSLAM()
        est = slam.run(Sequence(name=label, scans=scans))
        rows[label] = {
            "scans": len(scans),
            "mean_score": float(np.nanmean(est.diagnostics["score"])),
            "map_updates": est.meta["map_updates"],
            **map_sharpness(slam.map),
            "shared_hits_on_occupied": hits_on_occupied(slam.map, scans, est.poses[common], common),
            "wall_orientation_concentration": wall_orientation_concentration(slam.map),
            "ms_per_scan": 1e3 * float(np.mean(est.step_time)),
        }
        shared_poses[label] = est.poses[common]
        slam.map.save_png(OUT / f"fr-clinic_{first or 'all'}_{label.split()[0]}.png")
        print(first, label, {k: round(v, 4) if isinstance(v, float) else v for k, v in rows[label].items()})
    d = between(shared_poses["181-beam layout only"], shared_poses["all layouts"])
    rows["difference at shared scans"] = {
        "trans_median": float(np.median(np.hypot(d[:, 0], d[:, 1]))),
        "trans_max": float(np.hypot(d[:, 0], d[:, 1]).max()),
        "rot_median_deg": float(np.degrees(np.median(np.abs(d[:, 2])))),
        "rot_max_deg": float(np.degrees(np.abs(d[:, 2]).max())),
    }
    rows["log_s"] = float(stretch.t[-1] - stretch.t[0])
    print(first, rows["difference at shared scans"], rows["log_s"])
    path = OUT / "fr_clinic_interlaced.json"
    table = json.loads(path.read_text()) if path.exists() else {}
    table[str(first or "all")] = rows
    path.write_text(json.dumps(table, indent=2))


STUDIES = {"sim": study_sim, "carmen": study_carmen, "interlaced": study_interlaced}


def main() -> None:
    if len(sys.argv) != 2 or sys.argv[1] not in STUDIES:
        raise SystemExit(f"usage: python research/scripts/mapping_studies.py {{{','.join(STUDIES)}}}")
    STUDIES[sys.argv[1]]()


if __name__ == "__main__":
    main()
