"""Where FastSLAM fails on the real landmark data, per update (research/notebook/2026-11-28-fastslam-depletion.md).

    python research/scripts/fastslam_depletion.py DATASET '{"param": value}' SEED [SEED ...]

DATASET: ``vp_ids`` / ``vp_no_ids`` (the victoria_park config's ``fastslam_identified`` / ``fastslam_no_ids_identified``
rows; the reference is the with-ids iSAM2 smoother on the identified model, as research/scripts/fastslam_real_data_fix.py
computes it), or ``mrclam6:K`` (the mrclam config's ``fastslam`` row on Dataset 6, robot K; the reference is Vicon).
The JSON object is added to the row's parameters.

Per update it takes, from the run's Estimate: the error e of the weighted-mean position from the reference (no
alignment: every run starts at the reference's first pose), the cloud's σ_xy = √tr Σ_xy (the mixture covariance),
N_eff, the age t − t_A of the particles' most recent common ancestor, and (Victoria Park) the mean live landmarks per
particle against the trees seen so far (the file's ids). It prints, per tenth of the updates: max e, median e / σ_xy,
median N_eff, resamplings, median t − t_A [s], and the landmarks per tree seen; then the first update where e > 5 m,
where e / σ_xy > 10, and where the landmarks exceed the trees seen by 10 % (the map splits).
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

import slamarena
from slamarena import datasets
from slamarena.datasets.geometry import interpolate_poses
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.trajectory import ATEParams, ate

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from fastslam_real_data_fix import VP_ROWS, row, vp_reference  # noqa: E402


def reference(dataset: str):
    """(sequence, params of the row, reference t, reference poses, the reference for the ATE (MRCLAM) or None)."""
    if dataset in VP_ROWS:
        seq = datasets.load("victoria_park")
        t_ref, p_ref = vp_reference()
        return seq, row("victoria_park", VP_ROWS[dataset]), t_ref, p_ref, None
    k = int(dataset.split(":")[1])
    seq = datasets.load("utias", path="utias_mrclam/MRCLAM_Dataset6", robot=k)
    ref = reference_of(seq)
    return seq, row("mrclam", "fastslam"), ref.t, ref.poses, ref


def trees_seen(seq, t: np.ndarray) -> np.ndarray:
    """Distinct labelled landmarks observed up to each t (n,)."""
    rb = seq.range_bearing
    keep = rb.landmark_id >= 0
    ids, first = np.unique(rb.landmark_id[keep], return_index=True)
    first_t = np.sort(rb.t[keep][first])
    return np.searchsorted(first_t, t, side="right")


def first(mask: np.ndarray, t: np.ndarray) -> str:
    i = np.flatnonzero(mask)
    return f"update {i[0]} (t = {t[i[0]]:.1f} s)" if i.size else "never"


def diagnose(dataset: str, extra: dict, seed: int) -> None:
    seq, params, t_ref, p_ref, truth = reference(dataset)
    tic = time.process_time()
    est = slamarena.create("fastslam", **{**params, "seed": seed, **extra}).run(seq)
    cpu = time.process_time() - tic
    d = est.diagnostics
    tu = d["neff_t"]
    at = np.searchsorted(est.t, tu)  # the estimate's stamp of each update (the posterior at that stamp)
    at = np.clip(at, 0, len(est.t) - 1)
    ref = interpolate_poses(t_ref, p_ref, np.clip(tu, t_ref[0], t_ref[-1]))
    e = np.hypot(*(est.poses[at, :2] - ref[:, :2]).T)
    sigma = np.sqrt(np.trace(est.pose_cov[at, :2, :2], axis1=1, axis2=2))
    ratio = e / np.maximum(sigma, 1e-9)
    age = tu - d["common_ancestor_t"]
    split = None
    if dataset in VP_ROWS:
        split = d["landmarks_mean"] / np.maximum(trees_seen(seq, tu), 1)
    e_all = np.hypot(
        *(est.poses[:, :2] - interpolate_poses(t_ref, p_ref, np.clip(est.t, t_ref[0], t_ref[-1]))[:, :2]).T
    )
    aligned = (
        ""
        if truth is None
        else f" (ATE after SE(2) alignment {ate(est, truth, ATEParams(align='se2', max_gap=0.05))[0]['rmse']:.3f} m)"
    )
    print(
        f"{dataset} {extra} seed {seed}: RMSE {np.sqrt(np.mean(e_all**2)):.2f} max {e_all.max():.2f} "
        f"final {e_all[-1]:.2f} m{aligned}, {len(est.landmark_ids)} landmarks, {est.meta['resamplings']} resamplings of "
        f"{len(tu)} updates, cpu {cpu:.0f} s"
    )
    print("  updates      | max e [m] | med e/σ | med N_eff | resampl. | med t−t_A [s] | landmarks / trees seen")
    for part in np.array_split(np.arange(len(tu)), 10):
        s = f"{split[part[-1]]:.2f}" if split is not None else "–"
        print(
            f"  {part[0]:5d}–{part[-1]:5d} | {e[part].max():9.2f} | {np.median(ratio[part]):7.1f} | "
            f"{np.median(d['neff'][part]):9.1f} | {int(d['resampled'][part].sum()):8d} | {np.median(age[part]):13.1f} | {s}"
        )
    print(f"  first e > 5 m: {first(e > 5.0, tu)}; first e/σ > 10: {first(ratio > 10.0, tu)}", end="")
    print(f"; map splits (landmarks > 1.1 × trees seen): {first(split > 1.1, tu)}" if split is not None else "")


def main() -> None:
    dataset, extra, seeds = sys.argv[1], json.loads(sys.argv[2]), [int(s) for s in sys.argv[3:]]
    for seed in seeds:
        diagnose(dataset, extra, seed)


if __name__ == "__main__":
    main()
