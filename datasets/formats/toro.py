"""TORO text graphs (Grisetti et al.), with GTSAM's bearing–range extension.

Records (metres, radians)::

    VERTEX2 id x y θ
    EDGE2   i j dx dy dθ  I_xx I_xy I_yy I_θθ I_xθ I_yθ      pose j in the frame of i
    EQUIV   i j                                             i and j are the same pose
    BR      p l bearing range σ_bearing σ_range             (example.graph) landmark l seen from pose p

The six noise numbers of ``EDGE2`` are the **information** matrix in TORO's order
(xx, xy, yy, θθ, xθ, yθ) — not g2o's row-major upper triangle. ``BR`` lines become landmark edges
of kind ``"bearing_range"`` with ``z = (bearing, range)`` and information
diag(1/σ_bearing², 1/σ_range²). ``EQUIV`` pairs have no edge in :class:`PoseGraph`; they are kept
in ``meta["equivalences"]`` (and counted). Files whose ``EDGE2`` noise follows the iSAM
square-root convention (w20000) are read with :mod:`slamarena.datasets.formats.isam` instead.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from slamarena.params import Field, with_params

from ..errors import DataFormatError
from ..posegraph import PoseGraph
from ..source import Layout, SourceParams
from . import isam
from ._text import check_unique, integer_ids, record_values, records

__all__ = ["read", "load", "ToroSource", "toro_information", "RECORDS"]

RECORDS = {"VERTEX2": 4, "EDGE2": 11, "EQUIV": 2, "BR": 6}


def toro_information(values: np.ndarray) -> np.ndarray:
    """(K, 3, 3) information matrices from TORO's (xx, xy, yy, θθ, xθ, yθ) order."""
    xx, xy, yy, tt, xt, yt = values.T
    return np.stack([np.stack([xx, xy, xt], -1), np.stack([xy, yy, yt], -1), np.stack([xt, yt, tt], -1)], -2)


def read(path: str | Path, name: str | None = None) -> PoseGraph:
    """A TORO file as a :class:`PoseGraph`."""
    lines, tag = records(path, f"a TORO record ({', '.join(RECORDS)})")
    unknown = np.flatnonzero((tag != "") & ~np.isin(tag, list(RECORDS)))
    if unknown.size:
        k = int(unknown[0])
        raise DataFormatError(lines.path, k + 1, f"a TORO record ({', '.join(RECORDS)})", lines[k][:80])
    table = {}
    for record, ncols in RECORDS.items():
        rows = np.flatnonzero(tag == record)
        values = record_values(lines, rows, ncols, f"a {record} record")
        integer_ids(lines.path, values[:, :2] if record != "VERTEX2" else values[:, :1], rows + 1)
        table[record] = (values, rows)
    v, vrows = table["VERTEX2"]
    e, erows = table["EDGE2"]
    q, _ = table["EQUIV"]
    br, brows = table["BR"]
    info = toro_information(e[:, 5:11])
    isam.check_positive_definite(lines.path, info, erows + 1, "EDGE2")
    node_ids = v[:, 0].astype(np.int64)
    edge_ids = e[:, :2].astype(np.int64)
    if node_ids.size:
        check_unique(lines.path, node_ids, vrows + 1, "VERTEX2")
        missing = ~np.isin(edge_ids, node_ids).all(axis=1)
        if missing.any():
            k = int(np.flatnonzero(missing)[0])
            raise DataFormatError(
                lines.path, int(erows[k]) + 1, "an EDGE2 between declared vertices", str(edge_ids[k].tolist())
            )
    else:
        node_ids = np.unique(edge_ids)
    sig = br[:, 4:6]
    if (sig <= 0).any():
        k = int(np.flatnonzero((sig <= 0).any(axis=1))[0])
        raise DataFormatError(lines.path, int(brows[k]) + 1, "positive BR standard deviations", str(sig[k].tolist()))
    landmarks = {}
    if br.shape[0]:
        landmarks = dict(
            landmark_pose=br[:, 0].astype(np.int64),
            landmark_id=br[:, 1].astype(np.int64),
            landmark_z=br[:, 2:4],
            landmark_information=np.stack([np.diag(1.0 / s**2) for s in sig]),
            landmark_kind="bearing_range",
        )
    meta = {
        "format": "TORO",
        "file": lines.path,
        "noise_convention": "information (TORO order xx xy yy tt xt yt)",
        "equivalences": q.astype(np.int64).tolist(),
        "equivalence_count": int(q.shape[0]),
    }
    return PoseGraph(
        name=name or Path(path).name,
        node_ids=node_ids,
        edge_i=edge_ids[:, 0],
        edge_j=edge_ids[:, 1],
        edge_z=e[:, 2:5],
        edge_information=info,
        poses=v[:, 1:4] if v.shape[0] else None,
        dim=2,
        meta=meta,
        **landmarks,
    )


class ToroSource(SourceParams):
    """A TORO file; the reader has no options."""

    path: str = Field(description="a TORO graph file (VERTEX2, EDGE2, EQUIV, BR lines)")

    def layout(self) -> Layout:
        return Layout({"graph": (self.path,)})


@with_params(ToroSource)
def load(files: dict, name: str, /, *, params: ToroSource) -> PoseGraph:
    """The family reader: role ``graph``."""
    return read(files["graph"], name=name)
