"""EKF-SLAM studies behind research/ekf_slam.md: Monte Carlo consistency and real data.

    python -m slamarena.experiments.ekf_slam_study consistency [--seeds 30] [--laps 2] [--figure PATH]
                                                     [--sim JSON] [--variants standard FEJ ideal]
    python -m slamarena.experiments.ekf_slam_study realdata
    python -m slamarena.experiments.ekf_slam_study linearisation

``consistency``: robot-pose NEES over time of the standard, FEJ and ideal EKF (and the
standard EKF with the reference's zero-cross-covariance ``initP`` landmark initialisation) on
``sim:landmarks`` with the simulator's true noise, averaged over the seeds and compared with
the two-sided 95 % χ² band of an N-run average (Bailey et al. 2006; Huang et al. 2008).
Uses ``slamarena.experiments.metrics.consistency`` (NEES, Monte Carlo average, band).

``realdata``: UTIAS MRCLAM Dataset 6, every robot, known association (barcodes), with the sensor model of
the shipped config ``mrclam`` (:func:`mrclam_noise`): ATE against Vicon (SE(2)-aligned,
``slamarena.experiments.metrics.trajectory.ate``) and landmark-map error (``slamarena.experiments.metrics.landmarks``)
next to dead reckoning, with and without the outlier gate; Victoria Park with the ids withheld (nearest
neighbour and JCBB, without and with landmark management) against the run with ids. Every method on every robot:
``slamarena run mrclam``.

``linearisation``: the standard, FEJ and OC Jacobians on every MRCLAM Dataset 6 robot, gated (χ²₂(0.999), as in the
shipped config) and ungated: rows rejected, the longest lockout (``lockout_*`` diagnostics), the largest and final
position σ, ATE, NEES — or the error that stopped the run.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from slamarena import datasets
from slamarena.datasets.geometry import interpolate_poses, wrap_angle
from slamarena.estimators.dead_reckoning import DeadReckoning
from slamarena.estimators.ekf_slam import EKFSLAM
from slamarena.estimators.ekf_slam.association import Decision, chi2_gate
from slamarena.estimators.models import observe
from slamarena.experiments.metrics import MetricUnavailable, reference_of
from slamarena.experiments.metrics.consistency import monte_carlo, nees
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.trajectory import ate

VARIANTS = {
    "standard": dict(jacobians="standard"),
    "FEJ": dict(jacobians="fej"),
    "OC": dict(jacobians="oc"),
    "ideal": dict(jacobians="ideal"),
    "standard + initP": dict(jacobians="standard", init="initP", init_cov=1.0),
}



def mrclam_noise() -> dict:
    """MRCLAM's sensor model (``twist_cov`` per odometry row, ``range_bearing_cov``) as the shipped config
    ``experiments/configs/mrclam.yaml`` states it, once, for every method (its comments say how it was identified)."""
    from .config import load_config

    config = load_config("mrclam")
    ekf = config.estimators[config.estimator_labels().index("ekf_slam")]
    return {key: ekf.params[key] for key in ("twist_cov", "range_bearing_cov")}


def _nees_run(variant: str, seed: int, laps: int, sim: dict) -> tuple[np.ndarray, np.ndarray]:
    seq = datasets.load("sim:landmarks", seed=seed, laps=laps, **sim)
    est = EKFSLAM(**VARIANTS[variant]).run(seq)
    _, series = nees(est, reference_of(seq))
    return series["t"], series["nees"]


def consistency(seeds: int = 30, laps: int = 2, figure: str | None = None, jobs: int = 2,
                sim: dict | None = None, variants: list[str] | None = None) -> dict:
    from joblib import Parallel, delayed

    start = time.time()
    sim = sim or {}
    results = {}
    for variant in variants or list(VARIANTS):
        runs = Parallel(n_jobs=jobs)(delayed(_nees_run)(variant, s, laps, sim) for s in range(seeds))
        results[variant] = monte_carlo(runs, dof=3)
    print(f"sim:landmarks {sim}, {laps} laps, {seeds} seeds ({time.time() - start:.0f} s)")
    print(f"{'variant':18s} {'mean ANEES':>10s} {'ANEES 1st lap':>13s} {'ANEES last 10%':>14s} {'in 95% band':>11s}   band [lo, hi]")
    for variant, mc in results.items():
        t, m = mc["t"], mc["mean"]
        first = m[t <= t[0] + (t[-1] - t[0]) / laps]
        last = m[t >= t[-1] - 0.1 * (t[-1] - t[0])]
        print(f"{variant:18s} {m.mean():10.2f} {first.mean():13.2f} {last.mean():14.2f} {mc['in_band']:11.2f}   "
              f"[{mc['lo'][0]:.2f}, {mc['hi'][0]:.2f}]")
    if figure:
        _plot(results, seeds, laps, figure, sim)
    return results


def _plot(results: dict, seeds: int, laps: int, path: str, sim: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 3.6), dpi=90)
    for (variant, mc), colour in zip(results.items(), ("C3", "C0", "C2", "C1")):
        ax.plot(mc["t"], mc["mean"], lw=1.0, color=colour, label=variant)
    any_mc = next(iter(results.values()))
    ax.fill_between(any_mc["t"], any_mc["lo"], any_mc["hi"], color="0.8", label=f"95 % band, {seeds} runs")
    ax.axhline(3.0, color="0.4", lw=0.6, ls="--")
    ax.set_yscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("average robot-pose NEES (dof 3)")
    extra = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in sim.items())
    ax.set_title(f"EKF-SLAM consistency, {seeds} Monte Carlo runs of sim:landmarks, {laps} laps" + (f"\n{extra}" if extra else ""), fontsize=8)
    ax.legend(fontsize=7, loc="upper left", ncol=3)
    fig.tight_layout()
    fig.savefig(path)
    print(f"wrote {path}")


def _true_d2(seq, noise: dict) -> np.ndarray:
    """Per range-bearing row: νᵀ R⁻¹ ν of the row against Vicon and the surveyed landmark (R: the noise's; NaN if unsurveyed)."""
    rb, gt, lm = seq.range_bearing, seq.ground_truth, seq.landmarks
    xy = np.full((rb.t.size, 2), np.nan)
    known = np.isin(rb.landmark_id, lm.ids)
    order = np.argsort(lm.ids)
    xy[known] = lm.xy[order[np.searchsorted(lm.ids[order], rb.landmark_id[known])]]
    nu = rb.z[:, :2] - observe(interpolate_poses(gt.t, gt.poses, rb.t), xy)
    nu[:, 1] = wrap_angle(nu[:, 1])
    return np.einsum("ki,ij,kj->k", nu, np.linalg.inv(np.diag(noise["range_bearing_cov"])), nu)


def _rows_of(seq, t: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Range-bearing rows (indices) of the observations stamped t with landmark ids."""
    rb = seq.range_bearing
    key = {(float(a), int(b)): k for k, (a, b) in enumerate(zip(rb.t, rb.landmark_id))}
    return np.array([key[(float(a), int(b))] for a, b in zip(t, ids)], dtype=np.int64)


def realdata() -> None:
    noise = mrclam_noise()
    print("UTIAS MRCLAM Dataset 6, known association; noise (experiments/configs/mrclam.yaml)", noise)
    print("rejected: rows not applied / all rows; outliers: of the rejected rows, those whose residual against Vicon and the "
          "surveyed landmark is beyond the same χ²₂ gate under R")
    print(f"{'robot':7s} {'method':20s} {'ATE rmse [m]':>12s} {'ATE max [m]':>11s} {'map rmse [m]':>12s} {'NEES mean':>9s} "
          f"{'rejected':>11s} {'outliers':>8s} {'time [s]':>8s}")
    for robot in range(1, 6):
        seq = datasets.load(f"utias:6/robot{robot}")
        ref = reference_of(seq)
        true_d2 = _true_d2(seq, noise)
        methods = {"dead reckoning": DeadReckoning(), "EKF-SLAM, no gate": EKFSLAM(**noise, known_confidence=None),
                   "EKF-SLAM": EKFSLAM(**noise), "EKF-SLAM, gate 0.999": EKFSLAM(**noise, known_confidence=0.999),
                   "FEJ-EKF": EKFSLAM(**noise, jacobians="fej")}
        for name, method in methods.items():
            start = time.time()
            est = method.run(seq)
            spent = time.time() - start
            a, _ = ate(est, ref)
            m = landmark_error(est, ref)[0]["rmse"] if est.landmarks is not None and len(est.landmarks) else float("nan")
            try:
                n = nees(est, ref)[0]["mean"]
            except MetricUnavailable:  # dead reckoning without stated noise has no covariance
                n = float("nan")
            rejected, outliers = "", ""
            if "assoc_decision" in est.diagnostics:
                d = est.diagnostics
                out = d["assoc_decision"] == Decision.REJECTED
                confidence = method.params.known_confidence
                rejected = f"{out.sum()} / {out.size}"
                if confidence is not None:
                    outliers = str(int(np.sum(true_d2[_rows_of(seq, d["assoc_t"][out], d["assoc_given_id"][out])] > chi2_gate(confidence, 2))))
            print(f"robot{robot:<2d} {name:20s} {a['rmse']:12.3f} {a['max']:11.3f} {m:12.3f} {n:9.1f} {rejected:>11s} {outliers:>8s} {spent:8.1f}")
        confidence = EKFSLAM.Params().known_confidence
        print(f"robot{robot:<2d} {np.sum(true_d2 > chi2_gate(confidence, 2))} of {true_d2.size} rows have a residual against Vicon "
              f"beyond the default gate χ²₂({confidence}) = {chi2_gate(confidence, 2):.1f} under R")

    print("\nVictoria Park (6969 poses, 151 trees, stated Cartesian tree noise): ids withheld vs with ids")
    seq = datasets.load("victoria_park")
    with_ids = EKFSLAM(range_bearing_noise="cartesian", known_confidence=None).run(seq)  # every labelled row applied
    ref_traj = with_ids.poses
    print(f"with ids: {with_ids.meta['n_landmarks']} landmarks, NIS mean/dof {np.mean(with_ids.diagnostics['nis'] / with_ids.diagnostics['nis_dof']):.2f}")
    from slamarena.experiments.metrics.reference import Reference

    ref = Reference(with_ids.t, ref_traj, with_ids.landmark_ids, with_ids.landmarks, None)
    gated = EKFSLAM(range_bearing_noise="cartesian").run(seq)
    print(f"with ids and the default gate on labelled rows: {gated.meta['rejected']} of {gated.diagnostics['assoc_decision'].size} rows "
          f"rejected; trajectory vs the ungated run: ATE rmse {ate(gated, ref)[0]['rmse']:.2f} m")
    for method, gates in (("nn", {}), ("jcbb", {}), ("nn", dict(new_confidence=0.96))):
        start = time.time()
        est = EKFSLAM(use_ids=False, association=method, range_bearing_noise="cartesian", **gates).run(seq)
        spent = time.time() - start
        d = est.diagnostics
        dec, lm, given = d["assoc_decision"], d["assoc_landmark"], d["assoc_given_id"]
        creator = {int(a_): int(g_) for a_, g_ in zip(lm[dec == Decision.NEW], given[dec == Decision.NEW])}
        matched = dec == Decision.MATCHED
        right = np.array([creator[int(a_)] == int(g_) for a_, g_ in zip(lm[matched], given[matched])], dtype=bool)
        correct = right.mean() if matched.any() else float("nan")
        wrong_t = d["assoc_t"][matched][~right]
        seen, dup_t = set(), []
        for k in np.flatnonzero(dec == Decision.NEW):
            dup_t += [d["assoc_t"][k]] if int(given[k]) in seen else []
            seen.add(int(given[k]))
        distinct = len(set(creator.values()))
        a, _ = ate(est, ref)
        m = landmark_error(est, ref, MapParams(by="nearest", max_distance=5.0))[0]
        print(f"{method:5s} {gates}: first wrong match at t = {wrong_t[0] if wrong_t.size else None}, first duplicate "
              f"landmark at t = {dup_t[0] if dup_t else None}, observations rejected as ambiguous {(dec == Decision.REJECTED).sum()}")
        print(f"{method:5s}: {est.meta['n_landmarks']} landmarks created for {distinct} distinct trees "
              f"(151 in the data); matched {matched.sum()}, new {(dec == Decision.NEW).sum()}, rejected {(dec == Decision.REJECTED).sum()}; "
              f"matches consistent with the true ids {correct:.3f}; trajectory vs with-ids run: ATE rmse {a['rmse']:.2f} m, "
              f"max {a['max']:.2f} m; map vs with-ids map (nearest, 5 m): rmse {m['rmse']:.2f} m, matched {m['matched']}, "
              f"spurious {m['spurious']}; {spent:.0f} s")


def linearisation() -> None:
    noise = mrclam_noise()
    print(f"{'robot':7s} {'jacobians':9s} {'gate':>7s} {'rejected':>11s} {'lockout rows / s':>16s} {'σ max / final [m]':>17s} "
          f"{'ATE [m]':>7s} {'NEES':>7s}")
    for robot in range(1, 6):
        seq = datasets.load(f"utias:6/robot{robot}")
        ref = reference_of(seq)
        for jacobians in ("standard", "fej", "oc"):
            for gate in (0.999, None):
                head = f"robot{robot:<2d} {jacobians:9s} {str(gate):>7s}"
                try:
                    est = EKFSLAM(**noise, jacobians=jacobians, known_confidence=gate).run(seq)
                except Exception as exc:  # noqa: BLE001 — the failure is the result
                    print(f"{head} {type(exc).__name__}: {str(exc)[:120]}")
                    continue
                d = est.diagnostics
                out = d["assoc_decision"] == Decision.REJECTED
                sigma = np.sqrt(est.pose_cov[:, 0, 0] + est.pose_cov[:, 1, 1])
                lockout = f"{int(d['lockout_rows'])} / {float(d['lockout_s']):.0f}"
                print(f"{head} {f'{out.sum()} / {out.size}':>11s} {lockout:>16s} {f'{sigma.max():.2f} / {sigma[-1]:.2f}':>17s} "
                      f"{ate(est, ref)[0]['rmse']:7.2f} {nees(est, ref)[0]['mean']:7.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("consistency")
    c.add_argument("--seeds", type=int, default=30)
    c.add_argument("--laps", type=int, default=2)
    c.add_argument("--figure", default=None)
    c.add_argument("--jobs", type=int, default=2)
    c.add_argument("--sim", default="{}", help="simulator parameters as JSON, e.g. '{\"sigma_omega\": 0.1}'")
    c.add_argument("--variants", nargs="*", default=None, choices=list(VARIANTS))
    sub.add_parser("realdata")
    sub.add_parser("linearisation")
    args = parser.parse_args()
    if args.command == "consistency":
        consistency(args.seeds, args.laps, args.figure, args.jobs, json.loads(args.sim), args.variants)
    elif args.command == "linearisation":
        linearisation()
    else:
        realdata()


if __name__ == "__main__":
    main()
