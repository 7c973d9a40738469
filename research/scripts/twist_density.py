"""EKF-SLAM's twist noise per row or per second on MRCLAM (research/notebook/2026-11-28-twist-density.md).

    python research/scripts/twist_density.py configs OUTDIR    # writes OUTDIR/twist_d6.yaml and OUTDIR/twist_d1.yaml
    slamarena run OUTDIR/twist_d6.yaml --out OUTDIR/d6           # (and d1): one process at a time
    python research/scripts/twist_density.py table OUTDIR/d6     # per robot: per row against twist_period T
    python research/scripts/twist_density.py rows                # Dataset 6's odometry row lengths per robot
    PYTHON research/scripts/twist_density.py dump OUT.npz         # the shipped EKF rows on Dataset 6 robot 4 ...
    python research/scripts/twist_density.py same A.npz B.npz     # ... bit for bit the same under two checkouts?

The configs are the shipped ``mrclam`` (Dataset 6) and ``mrclam_withheld`` (Dataset 1) with only mrclam.yaml's three
EKF-SLAM rows (standard, FEJ, OC), each once as shipped and once with ``twist_period`` T (label suffix ``_T``). The
criterion, stated before the first run with T: every EKF row, every robot of Dataset 6, ATE(T) ≤ 1.10 ATE(per row) +
0.02 m, and the five robots' mean ATE not higher.
"""

from __future__ import annotations

import gzip
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

CONFIGS = Path(__file__).resolve().parents[2] / "experiments" / "configs"
T = 0.014367816  # mrclam.yaml: the row period the twist noise is stated for (1/69.6 s)
EKF_ROWS = ("ekf_slam", "ekf_slam_fej", "ekf_slam_oc")
COLUMNS = ["ate.rmse", "map.rmse", "nees.mean_over_dof", "nees.in_band", "estimate.rejected"]


def ekf_rows() -> list[dict]:
    """mrclam.yaml's EKF-SLAM rows as shipped, then each with twist_period T."""
    rows = [r for r in yaml.safe_load((CONFIGS / "mrclam.yaml").read_text())["estimators"] if r["name"] == "ekf_slam"]
    for r in rows:
        r.setdefault("label", r["name"])
    assert [r["label"] for r in rows] == list(EKF_ROWS), [r["label"] for r in rows]
    with_T = [{**r, "label": r["label"] + "_T", "params": {**r["params"], "twist_period": T}} for r in rows]
    return rows + with_T


def write_configs(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for source, name in (("mrclam", "twist_d6"), ("mrclam_withheld", "twist_d1")):
        config = yaml.safe_load((CONFIGS / f"{source}.yaml").read_text())
        config.pop("estimators_from", None)
        config.pop("figures", None)
        config.update(name=name, estimators=ekf_rows(), description=f"{source}'s EKF-SLAM rows, per row and with T")
        (out / f"{name}.yaml").write_text(yaml.safe_dump(config, sort_keys=False, allow_unicode=True))
        print(out / f"{name}.yaml")


def table(results: Path) -> None:
    d = pd.read_csv(results / "summary.csv")
    cols = [c for c in COLUMNS if c in d and d[c].notna().any()]
    for base in EKF_ROWS:
        a, b = (d[d.estimator == label].set_index("dataset")[cols] for label in (base, base + "_T"))
        print(f"\n{base}: per row | twist_period T")
        print(pd.concat({"row": a, "T": b}, axis=1).round(3).to_string())
        print(f"mean map.rmse: row {a['map.rmse'].mean():.3f}, T {b['map.rmse'].mean():.3f}")
        if "ate.rmse" in cols:
            ok = b["ate.rmse"] <= 1.10 * a["ate.rmse"] + 0.02
            print(
                f"mean ate.rmse: row {a['ate.rmse'].mean():.3f}, T {b['ate.rmse'].mean():.3f}; criterion met: {dict(ok)}"
            )


def rows() -> None:
    """Per robot of Dataset 6: the share of time in rows > 0.1 s and Σdt² / (Σdt T), the heading variance applying M per
    row carries against the stated density (rows of period T: 1)."""
    root = Path(__file__).resolve().parents[3] / "shared" / "datasets" / "utias_mrclam" / "MRCLAM_Dataset6"
    for robot in range(1, 6):
        with gzip.open(root / f"Robot{robot}_Odometry.dat.gz", "rt") as f:
            dt = np.diff(np.loadtxt(f, comments="#")[:, 0])
        print(
            f"robot{robot}: {len(dt)} rows, {dt.sum():.0f} s, time in rows > 0.1 s {100 * dt[dt > 0.1].sum() / dt.sum():.1f} %, "
            f"Σdt²/(Σdt·T) {(dt**2).sum() / (dt.sum() * T):.2f}, longest {dt.max():.2f} s"
        )


def dump(out: Path) -> None:
    """The shipped (per row) EKF-SLAM rows on Dataset 6 robot 4 with the code of the running interpreter's checkout:
    poses, pose covariances and landmarks, for :func:`same`."""
    from slamarena import datasets, estimators

    print(estimators.__file__)
    seq = datasets.load("utias", path="utias_mrclam/MRCLAM_Dataset6", robot=4)
    arrays = {}
    for r in ekf_rows()[: len(EKF_ROWS)]:
        est = estimators.create("ekf_slam", **r["params"]).run(seq)
        arrays.update({f"{r['label']}/{k}": getattr(est, k) for k in ("poses", "pose_cov", "landmarks")})
    np.savez(out, **arrays)


def same(a: Path, b: Path) -> None:
    with np.load(a) as x, np.load(b) as y:
        for k in x.files:
            print(k, "identical" if np.array_equal(x[k], y[k]) else f"differ by {np.abs(x[k] - y[k]).max():.3g}")


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["configs"]:
        write_configs(Path(argv[1]))
    elif argv[:1] == ["table"]:
        table(Path(argv[1]))
    elif argv[:1] == ["rows"]:
        rows()
    elif argv[:1] == ["dump"]:
        dump(Path(argv[1]))
    elif argv[:1] == ["same"]:
        same(Path(argv[1]), Path(argv[2]))
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main()
