"""notebook/2026-11-21-ekf-localizer-studies.md and 2026-11-21-ekf-localizer-real-data.md: the studies' tables.

Run from the repository root: ``python research/scripts/ekf_localizer_studies.py STUDY`` with STUDY one of
``q_unit``, ``consistency_by_source``, ``cmd_vel_vs_odometry``, ``imu``, ``mrclam`` (staged MRCLAM data); each prints
its table (minutes on a loaded machine). Moved from the slow tests of ``tests/estimators/test_ekf_localizer_study.py``
(issue 34), the same code without the assertions: the findings are claims of the shipped configs ``localizer_q_unit``
and ``gps_sweep`` (study 1's ATE, heading and NEES columns and study 5), and behaviour tests at one seed in
``tests/estimators/test_ekf_localizer_study.py`` (the rest).

Accuracy is ATE without alignment (GPS and the surveyed map fix the frame), from
:mod:`slamarena.experiments.metrics`; NEES is the single-run mean (3 when consistent).
"""

from __future__ import annotations

import sys

import numpy as np

from slamarena import datasets
from slamarena.estimators.ekf_localizer import EKFLocalizer
from slamarena.experiments.metrics.consistency import nees
from slamarena.experiments.metrics.reference import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate

SEEDS = range(10)


def _score(est, seq) -> dict:
    ref = reference_of(seq)
    a, _ = ate(est, ref, ATEParams(align="none"))
    n, _ = nees(est, ref)
    return {"ate": a["rmse"], "max": a["max"], "heading": a["heading_rmse"], "nees": n["mean"]}


def _mean(rows: list[dict]) -> dict:
    return {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}


def _table(title: str, header: list[str], rows: list[list]) -> str:
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)
    lines = [f"\n### {title}", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in rows]
    text = "\n".join(lines)
    print(text)
    return text


def _noise_of(source: str, seed: int, **sim) -> list:
    """twist_cov of the slip-free run of this seed: the tuning a user has before the wheels slip."""
    clean = {k: v for k, v in sim.items() if k != "slip"}
    return datasets.load("sim:localization", motion_source=source, seed=seed, **clean).noise.twist_cov.tolist()


def study_q_unit():
    """The notes' Q = diag(0.01, 0.01, 0.01) without a unit, on the notes' world (cmd_vel 50 Hz,
    GPS 5 Hz, IMU 50 Hz), 60 s with a 20 s GPS outage from 20 s, 10 seeds."""
    configs = {
        "notes Q per 0.02 s step (0.5 m²/s)": dict(Q=0.01, q_unit="per_step"),
        "notes Q per second (0.01 m²/s)": dict(Q=0.01, q_unit="per_second"),
        "simulator's stated twist noise, Q = 0": dict(Q=0.0, use_sequence_noise=True),
    }
    rows = []
    for name, cfg in configs.items():
        scores, cover = [], []
        for seed in SEEDS:
            seq = datasets.load("sim:localization", duration=60.0, gps_outages=[(20.0, 40.0)], seed=seed)
            est = EKFLocalizer(**cfg).run(seq)
            scores.append(_score(est, seq))
            end = np.flatnonzero(est.t < 40.0)[-1]  # last pose of the outage
            truth = reference_of(seq)
            k = np.searchsorted(truth.t, est.t[end] - 1e-9)
            err = np.linalg.norm(est.poses[end, :2] - truth.poses[k, :2])
            cover.append((np.sqrt(np.trace(est.pose_cov[end, :2, :2])), err))
        s = _mean(scores)
        sd, err = np.mean(cover, axis=0)
        rows.append([name, s["ate"], s["heading"], s["nees"], sd, err])
    _table(
        "Q unit (cmd_vel, GPS 5 Hz with a 20 s outage, 10 seeds)",
        [
            "process noise",
            "ATE RMSE [m]",
            "heading RMSE [rad]",
            "mean NEES (3 = consistent)",
            "σ_xy at outage end [m]",
            "error at outage end [m]",
        ],
        rows,
    )


def study_cmd_vel_vs_odometry():
    """Prediction from cmd_vel (the notes) or wheel odometry, with and without wheel slip
    (20–40 s, ground speed 80% of the wheel speed, or 95%/75% left/right), with GPS at 5 Hz
    throughout or lost from 15 to 45 s. Twist noise: each source's stated noise on the slip-free
    run of the same seed (the tuning a user has); IMU 10 Hz; 60 s; 10 seeds."""
    slips = {"none": [], "both wheels 0.8": [(20.0, 40.0, 0.8)], "left 0.95 / right 0.75": [(20.0, 40.0, 0.95, 0.75)]}
    outages = {"GPS 5 Hz": [], "GPS lost 15–45 s": [(15.0, 45.0)]}
    rows = []
    for slip_name, slip in slips.items():
        for gps_name, outage in outages.items():
            for source in ("cmd_vel", "odometry"):
                scores = []
                for seed in SEEDS:
                    sim = dict(duration=60.0, imu_rate=10.0, slip=slip, gps_outages=outage)
                    seq = datasets.load("sim:localization", motion_source=source, seed=seed, **sim)
                    noise = dict(
                        twist_cov=_noise_of(source, seed, **sim),
                        R_gps=seq.noise.gps_cov.tolist(),
                        R_imu=seq.noise.yaw_var,
                    )
                    est = EKFLocalizer(Q=0.0, **noise).run(seq)
                    scores.append(_score(est, seq))
                s = _mean(scores)
                rows.append([slip_name, gps_name, source, s["ate"], s["max"], s["heading"], s["nees"]])
    _table(
        "cmd_vel vs wheel odometry for prediction (10 seeds, 60 s)",
        ["slip", "GPS", "prediction from", "ATE RMSE [m]", "max error [m]", "heading RMSE [rad]", "mean NEES"],
        rows,
    )


def study_consistency_by_source():
    """50-seed Monte Carlo (10 s, GPS 5 Hz, IMU 10 Hz, initial error drawn from P0) with the
    simulator's stated noise: wheel odometry (white encoder error) vs cmd_vel (actuator lag and
    Ornstein–Uhlenbeck noise: time-correlated, which a white Q cannot describe), EULER vs ARC."""
    from slamarena.datasets.sequence import Sequence
    from slamarena.experiments.metrics.consistency import monte_carlo

    P0 = np.array([1e-4, 1e-4, 1e-3])
    rows = []
    for source in ("odometry", "cmd_vel"):
        for model in ("arc", "euler"):
            runs, nis = [], {"gps": [], "imu": []}
            for seed in range(50):
                seq = datasets.load("sim:localization", duration=10.0, imu_rate=10.0, motion_source=source, seed=seed)
                rng = np.random.default_rng(10_000 + seed)
                seq = Sequence(
                    **{**seq.__dict__, "initial_pose": seq.start_pose + np.sqrt(P0) * rng.standard_normal(3)}
                )
                est = EKFLocalizer(motion_model=model, Q=0.0, use_sequence_noise=True, initial_cov=P0.tolist()).run(seq)
                series = nees(est, reference_of(seq))[1]
                runs.append((series["t"], series["nees"]))
                for sensor in nis:
                    nis[sensor].append(est.diagnostics[f"nis_{sensor}"])
            mc = monte_carlo(runs, 3)
            rows.append(
                [
                    source,
                    model,
                    float(mc["in_band"]),
                    float(mc["mean"].mean()),
                    float(np.concatenate(nis["gps"]).mean()),
                    float(np.concatenate(nis["imu"]).mean()),
                ]
            )
    _table(
        "Monte Carlo consistency by prediction source (50 seeds × 10 s; band χ²(150)/50 = [2.36, 3.72])",
        [
            "prediction from",
            "model",
            "steps with mean NEES in band",
            "mean NEES",
            "mean NIS GPS (2)",
            "mean NIS IMU (1)",
        ],
        rows,
    )


def study_imu():
    """What the IMU-yaw update buys: with / without it, GPS at 5 Hz or 1 Hz, cmd_vel, true noise, 60 s, 10 seeds."""
    rows = []
    for gps_rate in (5.0, 1.0):
        for imu in (True, False):
            scores = []
            for seed in SEEDS:
                seq = datasets.load("sim:localization", duration=60.0, gps_rate=gps_rate, imu_rate=50.0, seed=seed)
                if not imu:
                    seq = type(seq)(**{**seq.__dict__, "heading": None})
                scores.append(_score(EKFLocalizer(Q=0.0, use_sequence_noise=True).run(seq), seq))
            s = _mean(scores)
            rows.append([f"{gps_rate:g} Hz", "yes" if imu else "no", s["ate"], s["heading"], s["nees"]])
    _table(
        "IMU yaw update (cmd_vel, IMU 50 Hz, 10 seeds, 60 s)",
        ["GPS rate", "IMU yaw", "ATE RMSE [m]", "heading RMSE [rad]", "mean NEES"],
        rows,
    )


def study_mrclam():
    """MRCLAM Dataset 6, every robot: odometry prediction + range-bearing to the surveyed landmarks,
    against dead reckoning of the same odometry (the filter with no measurements). The dataset states
    no noise; ``MRCLAM_FILTER`` and its derivation are in research/notebook/2026-11-21-ekf-localizer-real-data.md."""
    rows = []
    for robot in range(1, 6):
        seq = datasets.load(f"utias:6/robot{robot}")
        est = EKFLocalizer(**MRCLAM_FILTER).run(seq)
        dead = EKFLocalizer(**MRCLAM_FILTER).run(type(seq)(**{**seq.__dict__, "range_bearing": None}))
        s, d = _score(est, seq), _score(dead, seq)
        rej = est.meta["rejected"]["landmark"]
        nis = est.diagnostics["nis_landmark"][est.diagnostics["nis_landmark_accepted"]]
        near, far = _error_by_time_since_update(est, seq)
        rows.append(
            [
                f"robot{robot}",
                s["ate"],
                s["max"],
                s["heading"],
                s["nees"],
                near,
                far,
                d["ate"],
                d["max"],
                len(seq.range_bearing),
                rej.get("gate", 0),
                est.meta["recoveries"]["landmark"],
                float(nis.mean() / 2),
            ]
        )
    _table(
        "MRCLAM Dataset 6: EKF localization vs dead reckoning (ATE vs Vicon, no alignment)",
        [
            "robot",
            "EKF ATE RMSE [m]",
            "EKF max [m]",
            "EKF heading RMSE [rad]",
            "EKF mean NEES",
            "RMSE ≤ 1 s after a landmark update",
            "RMSE > 10 s after",
            "dead-reckoning ATE RMSE [m]",
            "dead-reckoning max [m]",
            "landmark rows",
            "gated out",
            "recoveries",
            "mean NIS/2 (accepted)",
        ],
        rows,
    )


def _error_by_time_since_update(est, seq) -> tuple[float, float]:
    """Position RMSE within 1 s of an accepted landmark update, and more than 10 s after one."""
    from slamarena.experiments.metrics.reference import associate

    match = associate(reference_of(seq), est.t, 0.1)
    err = np.linalg.norm(est.poses[match.index, :2] - match.gt[:, :2], axis=1)
    t = est.t[match.index]
    updates = est.diagnostics["nis_landmark_t"][est.diagnostics["nis_landmark_accepted"]]
    k = np.searchsorted(updates, t, side="right") - 1
    since = np.where(k >= 0, t - updates[np.maximum(k, 0)], np.inf)
    rmse = lambda m: float(np.sqrt(np.mean(err[m] ** 2))) if m.any() else float("nan")
    return rmse(since <= 1.0), rmse(since > 10.0)


#: the MRCLAM configuration (research/notebook/2026-11-21-ekf-localizer-real-data.md explains the choice)
MRCLAM_FILTER = dict(
    motion_model="arc", Q=(2e-4, 2e-4, 2e-3), q_unit="per_second", R_landmark=(0.15**2, 0.02**2), gate_confidence=0.999
)


STUDIES = {
    "q_unit": study_q_unit,
    "cmd_vel_vs_odometry": study_cmd_vel_vs_odometry,
    "consistency_by_source": study_consistency_by_source,
    "imu": study_imu,
    "mrclam": study_mrclam,
}


def main() -> None:
    if len(sys.argv) != 2 or sys.argv[1] not in STUDIES:
        raise SystemExit(f"usage: python research/scripts/ekf_localizer_studies.py {{{','.join(STUDIES)}}}")
    STUDIES[sys.argv[1]]()


if __name__ == "__main__":
    main()
