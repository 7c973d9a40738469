"""Victoria Park (Guivant & Nebot 2001; pre-processed by Ranganathan & Kaess for iSAM).

The file is in the iSAM text format (:mod:`slamarena.datasets.formats.isam`): 6968 ``ODOMETRY`` lines
forming one chain of 6969 poses, and 3640 ``LANDMARK`` lines (151 trees) giving each tree as a
Cartesian point ``(dx, dy)`` in the robot frame (x forward, y left). Poses and landmarks share
one id space. Two copies exist and differ only in their noise columns:

``variant="isam"``   square-root information R (row-major upper triangle), Λ = RᵀR
``variant="gtsam"``  covariance Σ (row-major upper triangle)

Both state the same noise: odometry Σ = diag(1e-4, 4e-6, 4e-6) (σx = 0.01 m, σy = 0.002 m,
σθ = 0.002 rad) and landmarks Σ = 0.4 I₂ m² (σ = 0.632 m per axis).

As a :class:`Sequence` (:func:`read`) the file has **no timestamps**: ``t`` is the pose index
(0 … 6968); the increment into pose k has ``t = k`` and the trees seen from pose k have ``t = k``
(``meta["time"]`` says so). Observations become range–bearing: r = hypot(dx, dy),
b = atan2(dy, dx). An isotropic Cartesian noise σ² I maps through the polar Jacobian
J = [[x/r, y/r], [−y/r², x/r²]] to J σ²I Jᵀ = diag(σ², σ²/r²) exactly (the off-diagonal terms
cancel): σ_r = σ, σ_b = σ / r depends on the range. ``Noise.range_bearing_cov`` therefore holds
diag(σ², σ²/r̃²) at the median observed range r̃, and the exact per-observation covariances are
in ``meta["range_bearing_cov_per_observation"]`` (M, 2, 2).

As a :class:`PoseGraph` (:func:`read_graph`): odometry edges and landmark edges of kind ``"xy"``.

Catalogued: ``victoria_park`` (GTSAM's copy; the GTSAM wheel ships it) and ``victoria_park:isam``; any
file in the format: ``victoria_park:<file>`` with its ``variant`` (:class:`VictoriaParkSource`).
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar, Literal

import numpy as np

from slamarena.params import Field, with_params

from ..errors import DataFormatError
from ..posegraph import PoseGraph
from ..sequence import Increments, Noise, RangeBearing, Sequence
from ..source import Layout, SourceParams
from . import isam

__all__ = ["read", "read_graph", "load", "VictoriaParkSource", "Variant", "CONVENTION"]

#: the two copies of the file
Variant = Literal["isam", "gtsam"]
#: variant → noise convention of its noise columns (:func:`slamarena.datasets.formats.isam.information`)
CONVENTION = {"isam": "sqrt_information", "gtsam": "covariance"}


def _convention(variant: str) -> str:
    if variant not in CONVENTION:
        raise ValueError(f"Victoria Park variant must be one of {sorted(CONVENTION)}, got {variant!r}")
    return CONVENTION[variant]


def read_graph(path: str | Path, variant: Variant = "isam", name: str = "victoria_park") -> PoseGraph:
    """The file as a pose graph with landmark edges (kind ``"xy"``)."""
    graph = isam.read(path, noise=_convention(variant), name=name, shared_ids=True)
    graph.meta.update(dataset="Victoria Park", variant=variant, ground_truth="none")
    return graph


def read(path: str | Path, variant: Variant = "isam", name: str = "victoria_park") -> Sequence:
    """The file as a :class:`Sequence` with :class:`Increments` motion and ``t`` = pose index."""
    convention = _convention(variant)
    rec = isam.read_records(path, allowed=("ODOMETRY", "LANDMARK"))
    if rec.pose_i.size == 0:
        raise DataFormatError(rec.path, None, "ODOMETRY records (the pose chain)", "none")
    chain_ok = rec.pose_i[1:] == rec.pose_j[:-1]
    if not chain_ok.all():
        k = int(np.flatnonzero(~chain_ok)[0]) + 1
        raise DataFormatError(
            rec.path,
            int(rec.pose_line[k]),
            f"ODOMETRY from the previous pose {rec.pose_j[k - 1]}",
            f"ODOMETRY {rec.pose_i[k]} {rec.pose_j[k]}",
        )
    pose_ids = np.concatenate([rec.pose_i[:1], rec.pose_j])
    index = np.searchsorted(pose_ids, rec.lm_pose)
    unknown = (index >= pose_ids.size) | (pose_ids[np.clip(index, 0, pose_ids.size - 1)] != rec.lm_pose)
    if pose_ids.size > 1 and np.any(np.diff(pose_ids) <= 0):
        k = int(np.flatnonzero(np.diff(pose_ids) <= 0)[0])
        raise DataFormatError(rec.path, int(rec.pose_line[k]), "increasing pose ids", str(pose_ids[k + 1]))
    if unknown.any():
        k = int(np.flatnonzero(unknown)[0])
        raise DataFormatError(
            rec.path, int(rec.lm_line[k]), "a LANDMARK seen from a pose of the odometry chain", str(rec.lm_pose[k])
        )
    if not np.all(np.diff(index) >= 0):
        k = int(np.flatnonzero(np.diff(index) < 0)[0]) + 1
        raise DataFormatError(rec.path, int(rec.lm_line[k]), "LANDMARK lines in pose order", str(rec.lm_pose[k]))

    odo_info, lm_info = isam.noise_information(rec, convention)
    odo_cov, lm_cov = np.linalg.inv(odo_info), np.linalg.inv(lm_info)
    motion = Increments(t=np.arange(1, pose_ids.size, dtype=float), delta=rec.pose_z, cov=odo_cov)
    rng = np.hypot(rec.lm_z[:, 0], rec.lm_z[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):  # a point at the sensor has no bearing: NaN, kept
        J = np.stack(
            [
                np.stack([rec.lm_z[:, 0] / rng, rec.lm_z[:, 1] / rng], -1),
                np.stack([-rec.lm_z[:, 1] / rng**2, rec.lm_z[:, 0] / rng**2], -1),
            ],
            -2,
        )
    bearing = np.arctan2(rec.lm_z[:, 1], rec.lm_z[:, 0])
    rb = RangeBearing(t=index.astype(float), range=rng, bearing=bearing, landmark_id=rec.lm_id)
    rb_cov = J @ lm_cov @ np.swapaxes(J, -1, -2)
    sigma2 = float(np.median(lm_cov[:, 0, 0])) if len(lm_cov) else 0.0
    r_med = float(np.median(rng)) if rng.size else 1.0
    noise = Noise(
        increment_cov=np.median(odo_cov, axis=0),
        range_bearing_cov=np.diag([sigma2, sigma2 / r_med**2]) if rng.size else None,
    )
    meta = {
        "dataset": "Victoria Park",
        "variant": variant,
        "file": rec.path,
        "noise_convention": convention,
        "time": "no timestamps in the file: t is the pose index",
        "pose_ids": pose_ids,
        "ground_truth_kind": "none",
        "landmark_noise": f"Cartesian sigma^2 = {sigma2:g} m^2 per axis; bearing std = sigma / range "
        f"(Noise.range_bearing_cov at the median range {r_med:.2f} m)",
        "range_bearing_cov_per_observation": rb_cov,
        "poses": int(pose_ids.size),
        "landmarks_observed": int(np.unique(rec.lm_id).size),
        "observations": int(rec.lm_id.size),
    }
    return Sequence(name=name, motion=motion, range_bearing=rb, initial_pose=np.zeros(3), noise=noise, meta=meta)


class VictoriaParkSource(SourceParams):
    """A Victoria Park file (what its noise columns hold belongs to the file) and the reader's option."""

    location: ClassVar[tuple[str, ...]] = ("path", "variant")
    path: str = Field(
        description="a file in the iSAM text format with ODOMETRY and LANDMARK lines (one odometry chain)"
    )
    variant: Variant = Field(
        "gtsam",
        description="what its noise columns hold: 'gtsam' covariance (GTSAM's copy) or "
        "'isam' square-root information (iSAM's copy)",
    )
    as_graph: bool = Field(False, description="a PoseGraph with landmark edges instead of a Sequence")

    def layout(self) -> Layout:
        return Layout({"file": (self.path,)})


@with_params(VictoriaParkSource)
def load(files: dict, name: str, /, *, params: VictoriaParkSource) -> Sequence | PoseGraph:
    """The family reader: role ``file``, read with the convention of ``variant``."""
    reader = read_graph if params.as_graph else read
    return reader(files["file"], params.variant, name)
