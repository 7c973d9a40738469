"""g2o text graphs (Kümmerle et al., ICRA 2011): read 2D and 3D, write 2D.

2D records (metres, radians)::

    VERTEX_SE2  id x y θ
    VERTEX_XY   id x y                                   a landmark's initial position
    EDGE_SE2    i j dx dy dθ  I11 I12 I13 I22 I23 I33    pose j in the frame of i; information
    EDGE_SE2_XY i l dx dy     I11 I12 I22                landmark l as a point in pose i's frame
    FIX id                                               (kept in meta["fixed"])

3D records: ``VERTEX_SE3:QUAT id x y z qx qy qz qw``; ``EDGE_SE3:QUAT i j dx dy dz qx qy qz qw``
followed by the 21-value upper triangle of the information (order x y z rx ry rz).

The noise columns are the row-major upper triangle of the **information** matrix Λ = Σ⁻¹.
Vertices and landmarks share one id space. A file without VERTEX lines (CSAIL, manhattan) gets
``poses = None``: the initial guess is the odometry chain. Landmark initial positions
(VERTEX_XY) are kept in ``meta["landmark_ids"]`` / ``meta["landmark_xy"]``. Any other record
type is an error (the reader does not silently ignore data).

``meta["content"]`` records the file's size and modification time and a digest of the arrays read from it
(:func:`fingerprint`), so that a consumer can tell whether a graph still holds exactly the file's content
(:func:`source_file`: the GTSAM pose-graph optimiser then lets GTSAM's C++ reader build its factor graph from the
file this reader has validated).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from slamarena.params import Field, with_params

from ..errors import DataFormatError
from ..posegraph import PoseGraph
from . import isam
from ._text import check_unique, integer_ids, record_values, records, symmetric_from_upper

__all__ = ["read", "write", "load", "fingerprint", "source_file", "G2oSource", "RECORDS_2D", "RECORDS_3D"]

RECORDS_2D = {"VERTEX_SE2": 4, "VERTEX_XY": 3, "EDGE_SE2": 11, "EDGE_SE2_XY": 7}
RECORDS_3D = {"VERTEX_SE3:QUAT": 8, "EDGE_SE3:QUAT": 30}
OTHER = {"FIX": 1}


def _ids(path: str, values: np.ndarray, rows: np.ndarray, cols) -> np.ndarray:
    return integer_ids(path, values[:, cols], rows + 1)


def _information(path: str, noise: np.ndarray, n: int, rows: np.ndarray, what: str) -> np.ndarray:
    """The information matrices (K, n, n) of the records on ``rows`` (0-based), each positive definite (iSAM's check)."""
    info = symmetric_from_upper(noise, n)
    isam.check_positive_definite(path, info, rows + 1, what)
    return info


def read(path: str | Path, name: str | None = None, ground_truth: str | Path | None = None) -> PoseGraph:
    """A g2o file as a :class:`PoseGraph` (2D, or 3D when it has SE3 records).

    ``ground_truth``: a noise-free iSAM file of the same poses (manhattan, city10000), whose
    odometry chain gives ``true_poses``.
    """
    known = {**RECORDS_2D, **RECORDS_3D, **OTHER}
    lines, tag = records(path, f"a g2o record ({', '.join(known)})")
    unknown = np.flatnonzero((tag != "") & ~np.isin(tag, list(known)))
    if unknown.size:
        k = int(unknown[0])
        raise DataFormatError(lines.path, k + 1, f"a g2o record ({', '.join(known)})", lines[k][:80])
    is3d = np.isin(tag, list(RECORDS_3D))
    is2d = np.isin(tag, list(RECORDS_2D))
    if is3d.any() and is2d.any():
        k = int(np.flatnonzero(is2d if np.flatnonzero(is3d)[0] < np.flatnonzero(is2d)[0] else is3d)[0])
        raise DataFormatError(lines.path, k + 1, "2D and 3D records not mixed in one file", lines[k][:80])
    table = {}
    for record, ncols in known.items():
        rows = np.flatnonzero(tag == record)
        values = record_values(lines, rows, ncols, f"a {record} record")
        table[record] = (values, rows)
    meta = {"format": "g2o", "file": lines.path, "noise_convention": "information"}
    fixed_ids = _ids(lines.path, *table["FIX"], 0)
    if fixed_ids.size:
        meta["fixed"] = fixed_ids.tolist()
    name = name or Path(path).name
    if is3d.any():
        v, vrows = table["VERTEX_SE3:QUAT"]
        e, erows = table["EDGE_SE3:QUAT"]
        return _graph(
            lines.path,
            name,
            3,
            _ids(lines.path, v, vrows, 0),
            v[:, 1:8],
            vrows,
            _ids(lines.path, e, erows, [0, 1]),
            e[:, 2:9],
            _information(lines.path, e[:, 9:30], 6, erows, "pose-constraint"),
            erows,
            meta,
        )
    v, vrows = table["VERTEX_SE2"]
    e, erows = table["EDGE_SE2"]
    lv, lvrows = table["VERTEX_XY"]
    le, lerows = table["EDGE_SE2_XY"]
    extra = {}
    if le.shape[0]:
        lm = _ids(lines.path, le, lerows, [0, 1])
        extra = dict(
            landmark_pose=lm[:, 0],
            landmark_id=lm[:, 1],
            landmark_z=le[:, 2:4],
            landmark_information=_information(lines.path, le[:, 4:7], 2, lerows, "landmark"),
            landmark_kind="xy",
        )
    if lv.shape[0]:
        meta["landmark_ids"] = _ids(lines.path, lv, lvrows, 0)
        meta["landmark_xy"] = lv[:, 1:3]
    graph = _graph(
        lines.path,
        name,
        2,
        _ids(lines.path, v, vrows, 0),
        v[:, 1:4],
        vrows,
        _ids(lines.path, e, erows, [0, 1]),
        e[:, 2:5],
        _information(lines.path, e[:, 5:11], 3, erows, "pose-constraint"),
        erows,
        meta,
        **extra,
    )
    if ground_truth is not None:
        true_poses, _ = isam.true_poses_and_landmarks(ground_truth, graph.node_ids)
        graph = PoseGraph(
            **{**graph.__dict__, "true_poses": true_poses, "meta": {**graph.meta, "ground_truth": str(ground_truth)}}
        )
    graph.meta["content"] = {"stat": _stat(lines.path), "fingerprint": fingerprint(graph)}
    return graph


#: the PoseGraph fields a g2o file holds (what an optimiser reads of it)
_CONTENT = (
    "node_ids",
    "poses",
    "edge_i",
    "edge_j",
    "edge_z",
    "edge_information",
    "landmark_pose",
    "landmark_id",
    "landmark_z",
    "landmark_information",
)


def fingerprint(graph: PoseGraph) -> str:
    """A digest (BLAKE2b) of what a g2o file gives a graph: its dimension, landmark kind, and the dtype, shape and bytes
    of each of its node, edge and landmark arrays; equal fingerprints mean equal arrays."""
    digest = hashlib.blake2b(f"{graph.dim} {graph.landmark_kind}".encode(), digest_size=16)
    for name in _CONTENT:
        a = getattr(graph, name)
        digest.update(name.encode())
        if a is not None:
            a = np.ascontiguousarray(a)
            digest.update(f"{a.dtype.str} {a.shape}".encode())
            digest.update(a.tobytes())
    return digest.hexdigest()


def _stat(path: str) -> list[int]:
    st = os.stat(path)
    return [st.st_size, st.st_mtime_ns]


def source_file(graph: PoseGraph) -> Path | None:
    """The g2o file ``graph`` was read from (:func:`read`) if the graph still holds exactly that file's content and the
    file is unchanged since (same size and modification time, same :func:`fingerprint`); None otherwise (a graph
    built or edited in memory, another format, a file changed or gone)."""
    content = graph.meta.get("content")
    if graph.meta.get("format") != "g2o" or not isinstance(content, dict) or "file" not in graph.meta:
        return None
    try:
        if _stat(graph.meta["file"]) != content.get("stat"):
            return None
    except OSError:
        return None
    return Path(graph.meta["file"]) if fingerprint(graph) == content.get("fingerprint") else None


def _graph(path, name, dim, vertex_ids, vertex_poses, vrows, edge_ids, z, info, erows, meta, **landmarks) -> PoseGraph:
    if vertex_ids.size:
        node_ids, poses = vertex_ids, vertex_poses
        check_unique(path, node_ids, vrows + 1, "vertex")
        missing = ~np.isin(edge_ids, node_ids).all(axis=1)
        if missing.any():
            k = int(np.flatnonzero(missing)[0])
            raise DataFormatError(
                path, int(erows[k]) + 1, "an edge between declared vertices", str(edge_ids[k].tolist())
            )
    else:
        pose_ends = [edge_ids.ravel()]
        if "landmark_pose" in landmarks:
            pose_ends.append(landmarks["landmark_pose"])
        node_ids, poses = np.unique(np.concatenate(pose_ends)), None
    return PoseGraph(
        name=name,
        node_ids=node_ids,
        edge_i=edge_ids[:, 0],
        edge_j=edge_ids[:, 1],
        edge_z=z,
        edge_information=info,
        poses=poses,
        dim=dim,
        meta=meta,
        **landmarks,
    )


def _fmt(a: np.ndarray) -> list[str]:
    return [" ".join(f"{x:.17g}" for x in row) for row in np.atleast_2d(a)]


def write(path: str | Path, graph: PoseGraph) -> None:
    """Write a 2D graph in g2o (VERTEX_SE2 for the initial poses, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY).

    Numbers are written with 17 significant digits, so :func:`read` returns the same values. A graph
    without initial poses (``poses=None``) gets VERTEX lines from its odometry chain. g2o has one id
    space: landmark ids that collide with pose ids are refused.
    """
    if graph.dim != 2:
        raise ValueError("g2o.write writes 2D graphs only")
    rows, cols = np.triu_indices(3)
    out: list[str] = []
    poses = graph.initial_poses()
    out += [f"VERTEX_SE2 {i} {p}" for i, p in zip(graph.node_ids, _fmt(poses))]
    if "landmark_ids" in graph.meta:
        out += [f"VERTEX_XY {i} {p}" for i, p in zip(graph.meta["landmark_ids"], _fmt(graph.meta["landmark_xy"]))]
    info = graph.edge_information[:, rows, cols]
    out += [
        f"EDGE_SE2 {i} {j} {z} {n}" for i, j, z, n in zip(graph.edge_i, graph.edge_j, _fmt(graph.edge_z), _fmt(info))
    ]
    if graph.landmark_pose is not None:
        if np.isin(graph.landmark_id, graph.node_ids).any():
            raise ValueError("g2o shares one id space between poses and landmarks; landmark ids collide with pose ids")
        if graph.landmark_kind != "xy":
            raise ValueError("g2o.write writes landmark edges of kind 'xy' only")
        r2, c2 = np.triu_indices(2)
        linfo = graph.landmark_information[:, r2, c2]
        out += [
            f"EDGE_SE2_XY {i} {j} {z} {n}"
            for i, j, z, n in zip(graph.landmark_pose, graph.landmark_id, _fmt(graph.landmark_z), _fmt(linfo))
        ]
    Path(path).write_text("\n".join(out) + "\n")


class G2oSource(isam.GraphSource):
    """A g2o file and, where there is one, its noise-free iSAM counterpart; the reader has no options."""

    path: str = Field(description="a g2o file (2D or 3D)")


@with_params(G2oSource)
def load(files: dict, name: str, /, *, params: G2oSource) -> PoseGraph:
    """The family reader: roles ``graph`` and, with ``ground_truth``, ``ground_truth`` (a noise-free iSAM file)."""
    return read(files["graph"], name=name, ground_truth=files.get("ground_truth"))
