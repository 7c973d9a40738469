"""The data model of a pose graph (g2o, TORO, iSAM files, Victoria Park as a graph).

2D graphs (``dim == 2``)
    nodes     ids (N,), poses (N, 3) ``(x, y, theta)`` initial guesses (``None`` when the file
              has none: :meth:`PoseGraph.chain_initialisation` composes the odometry chain)
    edges     i (E,), j (E,), z (E, 3) the pose of j in the frame of i, information (E, 3, 3)
              in the order (x, y, theta)
    landmark edges (optional): pose (L,), landmark (L,), z (L, 2), information (L, 2, 2), and
              ``landmark_kind`` saying what z is: ``"xy"`` (Cartesian point in the robot frame)
              or ``"bearing_range"``.
3D graphs (``dim == 3``, read only)
    poses (N, 7) ``(x, y, z, qx, qy, qz, qw)``, z (E, 7), information (E, 6, 6) order (x y z rx ry rz).

Ground truth, where a dataset has it: ``true_poses`` (N, 3) aligned with ``node_ids`` and
``true_landmarks`` (a :class:`~slamarena.datasets.sequence.LandmarkMap`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .geometry import accumulate
from .sequence import LandmarkMap

__all__ = ["PoseGraph"]


@dataclass(frozen=True)
class PoseGraph:
    name: str
    node_ids: np.ndarray
    edge_i: np.ndarray
    edge_j: np.ndarray
    edge_z: np.ndarray
    edge_information: np.ndarray
    poses: np.ndarray | None = None
    dim: int = 2
    landmark_pose: np.ndarray | None = None
    landmark_id: np.ndarray | None = None
    landmark_z: np.ndarray | None = None
    landmark_information: np.ndarray | None = None
    landmark_kind: str = "xy"
    true_poses: np.ndarray | None = None
    true_landmarks: LandmarkMap | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.dim not in (2, 3):
            raise ValueError("PoseGraph.dim must be 2 or 3")
        p = 3 if self.dim == 2 else 7
        r = 3 if self.dim == 2 else 6
        ints = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731
        object.__setattr__(self, "node_ids", ints(self.node_ids))
        object.__setattr__(self, "edge_i", ints(self.edge_i))
        object.__setattr__(self, "edge_j", ints(self.edge_j))
        object.__setattr__(self, "edge_z", np.ascontiguousarray(self.edge_z, dtype=float).reshape(-1, p))
        object.__setattr__(
            self, "edge_information", np.ascontiguousarray(self.edge_information, dtype=float).reshape(-1, r, r)
        )
        e = self.edge_i.shape[0]
        for key in ("edge_j", "edge_z", "edge_information"):
            if getattr(self, key).shape[0] != e:
                raise ValueError(f"PoseGraph.{key} has {getattr(self, key).shape[0]} rows, edge_i has {e}")
        if np.unique(self.node_ids).size != self.node_ids.size:
            raise ValueError("PoseGraph.node_ids are not unique")
        known = np.isin(np.concatenate([self.edge_i, self.edge_j]), self.node_ids)
        if not known.all():
            raise ValueError("PoseGraph has edges between unknown nodes")
        if not (np.isfinite(self.edge_z).all() and np.isfinite(self.edge_information).all()):
            raise ValueError("PoseGraph edges have non-finite values")
        if self.poses is not None:
            object.__setattr__(self, "poses", np.ascontiguousarray(self.poses, dtype=float).reshape(-1, p))
            if self.poses.shape[0] != self.node_ids.shape[0]:
                raise ValueError("PoseGraph.poses and node_ids differ in length")
        if self.landmark_pose is not None:
            object.__setattr__(self, "landmark_pose", ints(self.landmark_pose))
            object.__setattr__(self, "landmark_id", ints(self.landmark_id))
            object.__setattr__(self, "landmark_z", np.ascontiguousarray(self.landmark_z, dtype=float).reshape(-1, 2))
            object.__setattr__(
                self,
                "landmark_information",
                np.ascontiguousarray(self.landmark_information, dtype=float).reshape(-1, 2, 2),
            )
            n = self.landmark_pose.shape[0]
            for key in ("landmark_id", "landmark_z", "landmark_information"):
                if getattr(self, key).shape[0] != n:
                    raise ValueError(f"PoseGraph.{key} differs in length from landmark_pose")
            if self.landmark_kind not in ("xy", "bearing_range"):
                raise ValueError("PoseGraph.landmark_kind must be 'xy' or 'bearing_range'")
        if self.true_poses is not None:
            object.__setattr__(self, "true_poses", np.ascontiguousarray(self.true_poses, dtype=float).reshape(-1, p))

    @property
    def n_nodes(self) -> int:
        return int(self.node_ids.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edge_i.shape[0])

    def index_of(self, ids: np.ndarray) -> np.ndarray:
        """Row indices of node ids (vectorised)."""
        order = np.argsort(self.node_ids)
        pos = np.searchsorted(self.node_ids, ids, sorter=order)
        return order[np.clip(pos, 0, len(order) - 1)]

    def odometry_mask(self) -> np.ndarray:
        """Edges linking consecutive nodes (``j`` the node after ``i`` in node order)."""
        idx_i, idx_j = self.index_of(self.edge_i), self.index_of(self.edge_j)
        return idx_j == idx_i + 1

    def chain_initialisation(self) -> np.ndarray:
        """Initial poses from composing the odometry chain from the first node at the origin (2D)."""
        if self.dim != 2:
            raise NotImplementedError("chain initialisation is implemented for 2D graphs")
        rows_i, rows_j = self.index_of(self.edge_i), self.index_of(self.edge_j)
        chain = np.flatnonzero(rows_j == rows_i + 1)
        rows, first = np.unique(rows_j[chain], return_index=True)
        if rows.size != self.n_nodes - 1:
            missing = np.setdiff1d(np.arange(1, self.n_nodes), rows)
            raise ValueError(f"{self.name}: node {self.node_ids[missing[0]]} has no odometry edge from its predecessor")
        return accumulate(np.zeros(3), self.edge_z[chain[first]])

    def initial_poses(self) -> np.ndarray:
        """The file's initial guesses, or the odometry chain when the file has none."""
        return self.poses if self.poses is not None else self.chain_initialisation()

    def summary(self) -> dict:
        out = {
            "name": self.name,
            "dim": self.dim,
            "nodes": self.n_nodes,
            "edges": self.n_edges,
            "odometry_edges": int(self.odometry_mask().sum()),
            "loop_edges": int((~self.odometry_mask()).sum()),
            "has_initial_guess": self.poses is not None,
            "landmark_edges": 0 if self.landmark_pose is None else int(self.landmark_pose.shape[0]),
            "landmarks": 0 if self.landmark_id is None else int(np.unique(self.landmark_id).size),
            "ground_truth": self.true_poses is not None,
        }
        out["meta"] = {
            k: v for k, v in self.meta.items() if isinstance(v, (str, int, float, bool, list, dict, type(None)))
        }
        return out
