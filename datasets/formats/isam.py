"""iSAM 2D text format (Kaess et al.): pose graphs and pose+landmark graphs, in time order.

Every record is ``NAME id1 id2 measurement… noise…`` (whitespace separated, metres, radians)::

    ODOMETRY i j dx dy dθ  r11 r12 r13 r22 r23 r33     pose j in the frame of pose i
    EDGE2    i j dx dy dθ  r11 r12 r13 r22 r23 r33     the same (city10000, w20000)
    LANDMARK p l dx dy     r11 r12 r22                 landmark l as a Cartesian point in pose p's frame

The noise columns are the row-major upper triangle of the **square-root information** matrix R,
so the information is ``Λ = RᵀR`` (iSAM; GTSAM's copy of Victoria Park instead stores the
covariance upper triangle: ``noise="covariance"``). There are no VERTEX lines: the initial guess is
the odometry chain (:meth:`PoseGraph.chain_initialisation`).

Ground-truth files (``groundtruth/*_groundtruth.txt``) hold the same constraints without noise:
the true poses are the composition of the consecutive constraints ``i → i+1`` from (0, 0, 0), the
true landmarks ``pose ⊕ (dx, dy)`` of their first noise-free observation.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar, Literal, get_args

import numpy as np

from slamarena.params import Field, with_params

from ..errors import DataFormatError
from ..geometry import accumulate, transform_points
from ..posegraph import PoseGraph
from ..sequence import LandmarkMap
from ..source import Layout, SourceParams
from ._text import integer_ids, record_values, records, symmetric_from_upper, upper_triangular

__all__ = [
    "IsamRecords",
    "read_records",
    "information",
    "noise_information",
    "check_positive_definite",
    "read",
    "true_poses_and_landmarks",
    "load",
    "GraphSource",
    "IsamSource",
    "NoiseConvention",
]

POSE_TAGS = ("ODOMETRY", "EDGE2")
#: what a record's noise columns hold (:func:`information`)
NoiseConvention = Literal["sqrt_information", "covariance", "information"]
NOISE_CONVENTIONS = get_args(NoiseConvention)


@dataclass(frozen=True)
class IsamRecords:
    """The records of an iSAM-style file, in file order per kind.

    pose: i, j (E,), z (E, 3), noise (E, 6), line (E,)    landmark: p, l (L,), z (L, 2), noise (L, 3), line (L,)
    """

    path: str
    pose_i: np.ndarray
    pose_j: np.ndarray
    pose_z: np.ndarray
    pose_noise: np.ndarray
    pose_line: np.ndarray
    lm_pose: np.ndarray
    lm_id: np.ndarray
    lm_z: np.ndarray
    lm_noise: np.ndarray
    lm_line: np.ndarray


def read_records(path: str | Path, allowed: tuple[str, ...] = ("ODOMETRY", "EDGE2", "LANDMARK")) -> IsamRecords:
    """Parse the ODOMETRY/EDGE2 and LANDMARK records (any other record type is an error)."""
    lines, tag = records(path, f"a record of type {' / '.join(allowed)}")
    unknown = np.flatnonzero((tag != "") & ~np.isin(tag, allowed))
    if unknown.size:
        k = int(unknown[0])
        raise DataFormatError(lines.path, k + 1, f"a record of type {' / '.join(allowed)}", lines[k][:80])
    pose_rows = np.flatnonzero(np.isin(tag, POSE_TAGS))
    lm_rows = np.flatnonzero(tag == "LANDMARK")
    p = record_values(lines, pose_rows, 11, "a pose constraint (i j dx dy dtheta + 6 noise values)")
    q = record_values(lines, lm_rows, 7, "a LANDMARK record (p l dx dy + 3 noise values)")
    for arr, rows in ((p, pose_rows), (q, lm_rows)):
        integer_ids(lines.path, arr[:, :2], rows + 1)
    return IsamRecords(
        path=lines.path,
        pose_i=p[:, 0].astype(np.int64),
        pose_j=p[:, 1].astype(np.int64),
        pose_z=p[:, 2:5],
        pose_noise=p[:, 5:11],
        pose_line=pose_rows + 1,
        lm_pose=q[:, 0].astype(np.int64),
        lm_id=q[:, 1].astype(np.int64),
        lm_z=q[:, 2:4],
        lm_noise=q[:, 4:7],
        lm_line=lm_rows + 1,
    )


def information(noise: np.ndarray, n: int, convention: str) -> np.ndarray:
    """Information matrices ``(K, n, n)`` from row-major upper triangles in the given convention.

    ``sqrt_information``: Λ = RᵀR (iSAM); ``covariance``: Λ = Σ⁻¹ (GTSAM's Victoria Park);
    ``information``: Λ itself (g2o).
    """
    if convention == "sqrt_information":
        R = upper_triangular(noise, n)
        return np.einsum("kji,kjl->kil", R, R)
    if convention == "covariance":
        return np.linalg.inv(symmetric_from_upper(noise, n))
    if convention == "information":
        return symmetric_from_upper(noise, n)
    raise ValueError(f"noise convention must be one of {NOISE_CONVENTIONS}, got {convention!r}")


#: largest condition number of a noise matrix taken as positive definite: beyond it the matrix is singular to rounding
#: (the staged files' matrices are within 625) and its inverse meaningless
MAX_CONDITION = 1e12


def check_positive_definite(path: str, matrices: np.ndarray, lines: np.ndarray, what: str) -> None:
    """Raise at the line (``lines`` (K,), 1-based) of the first of ``matrices`` (K, n, n) that is not positive definite
    (smallest eigenvalue not above the largest / :data:`MAX_CONDITION`); shared by the graph readers."""
    if matrices.shape[0] == 0:
        return
    eig = np.linalg.eigvalsh(matrices)
    bad = np.flatnonzero(~(eig[:, 0] > eig[:, -1] / MAX_CONDITION))
    if bad.size:
        raise DataFormatError(
            path,
            int(lines[bad[0]]),
            f"a positive-definite {what} noise matrix (condition number below {MAX_CONDITION:g})",
            f"eigenvalues {eig[bad[0]].tolist()}",
        )


def noise_information(rec: IsamRecords, convention: str) -> tuple[np.ndarray, np.ndarray]:
    """Information matrices of the pose and landmark records, each checked positive definite at its line."""
    out = []
    for noise, n, lines, what in (
        (rec.pose_noise, 3, rec.pose_line, "pose-constraint"),
        (rec.lm_noise, 2, rec.lm_line, "landmark"),
    ):
        if convention == "covariance":
            check_positive_definite(rec.path, symmetric_from_upper(noise, n), lines, what)
        info = information(noise, n, convention)
        check_positive_definite(rec.path, info, lines, what)
        out.append(info)
    return out[0], out[1]


def read(
    path: str | Path,
    noise: NoiseConvention = "sqrt_information",
    ground_truth: str | Path | None = None,
    name: str | None = None,
    shared_ids: bool = False,
) -> PoseGraph:
    """An iSAM-format file as a :class:`PoseGraph` (landmark edges of kind ``"xy"``).

    ``shared_ids``: poses and landmarks share one id space (Victoria Park); otherwise landmark ids
    are their own space (cityTrees10000). ``ground_truth``: the noise-free file of the same graph.
    """
    rec = read_records(path)
    info, lm_info = noise_information(rec, noise)
    node_ids = np.unique(np.concatenate([rec.pose_i, rec.pose_j, rec.lm_pose]))
    if shared_ids and np.isin(rec.lm_id, node_ids).any():
        k = int(np.flatnonzero(np.isin(rec.lm_id, node_ids))[0])
        raise DataFormatError(
            rec.path, int(rec.lm_line[k]), "a landmark id distinct from every pose id", str(rec.lm_id[k])
        )
    meta = {
        "format": "iSAM text",
        "file": rec.path,
        "noise_convention": noise,
        "landmark_id_space": "shared with poses" if shared_ids else "separate from poses",
    }
    true_poses = true_landmarks = None
    if ground_truth is not None:
        true_poses, true_landmarks = true_poses_and_landmarks(ground_truth, node_ids)
        meta["ground_truth"] = str(ground_truth)
    has_lm = rec.lm_pose.size > 0
    return PoseGraph(
        name=name or Path(path).name,
        node_ids=node_ids,
        edge_i=rec.pose_i,
        edge_j=rec.pose_j,
        edge_z=rec.pose_z,
        edge_information=info,
        poses=None,
        dim=2,
        landmark_pose=rec.lm_pose if has_lm else None,
        landmark_id=rec.lm_id if has_lm else None,
        landmark_z=rec.lm_z if has_lm else None,
        landmark_information=lm_info if has_lm else None,
        landmark_kind="xy",
        true_poses=true_poses,
        true_landmarks=true_landmarks,
        meta=meta,
    )


def true_poses_and_landmarks(path: str | Path, node_ids: np.ndarray) -> tuple[np.ndarray, LandmarkMap | None]:
    """True poses (aligned with ``node_ids``) and landmarks from a noise-free iSAM file."""
    rec = read_records(path)
    chain = np.flatnonzero(rec.pose_j == rec.pose_i + 1)
    j, first = np.unique(rec.pose_j[chain], return_index=True)
    start = int(min(rec.pose_i.min(initial=0), 0))
    expected = np.arange(start + 1, start + 1 + j.size)
    if not np.array_equal(j, expected):
        missing = np.setdiff1d(np.arange(start + 1, j.max(initial=start) + 1), j)
        raise DataFormatError(
            rec.path, None, "a consecutive constraint i → i+1 for every pose", f"none into pose {missing[:1].tolist()}"
        )
    poses = accumulate(np.zeros(3), rec.pose_z[chain[first]])
    ids = np.arange(start, start + poses.shape[0])
    row = np.searchsorted(ids, node_ids)
    if (row >= ids.size).any() or not np.array_equal(ids[np.clip(row, 0, ids.size - 1)], node_ids):
        raise DataFormatError(rec.path, None, "ground truth for every pose of the graph", f"poses {ids[0]}..{ids[-1]}")
    landmarks = None
    if rec.lm_id.size:
        lm, first_obs = np.unique(rec.lm_id, return_index=True)
        seen_from = poses[np.searchsorted(ids, rec.lm_pose[first_obs])]
        landmarks = LandmarkMap(ids=lm, xy=transform_points(seen_from, rec.lm_z[first_obs]))
    return poses[row], landmarks


class GraphSource(SourceParams):
    """A graph file and, where there is one, the noise-free iSAM file of the same graph (its true poses)."""

    location: ClassVar[tuple[str, ...]] = ("path", "ground_truth")
    path: str = Field(description="a graph file")
    ground_truth: str | None = Field(
        None, description="the noise-free iSAM file of the same graph, found where the graph is; None: no ground truth"
    )

    def layout(self) -> Layout:
        return Layout({"graph": (self.path,), **({"ground_truth": (self.ground_truth,)} if self.ground_truth else {})})


class IsamSource(GraphSource):
    """An iSAM file (what its noise columns hold belongs to the file)."""

    location: ClassVar[tuple[str, ...]] = ("path", "ground_truth", "noise")
    path: str = Field(description="a file in the iSAM text format (ODOMETRY/EDGE2 and LANDMARK lines)")
    noise: NoiseConvention = Field(
        "sqrt_information", description="what the noise columns hold (iSAM files: the square-root information)"
    )


@with_params(IsamSource)
def load(files: dict, name: str, /, *, params: IsamSource) -> PoseGraph:
    """The family reader: roles ``graph`` and, with ``ground_truth``, ``ground_truth``."""
    return read(files["graph"], noise=params.noise, ground_truth=files.get("ground_truth"), name=name)
