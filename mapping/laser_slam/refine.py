"""Local refinement of laser graph SLAM: the scans between the nodes placed by pairwise ICP, the nodes held where the
pose graph put them.

The node graph (:mod:`.backend`) holds the front end's poses L_i of the nodes only; every other scan k hangs off its
node i(k) rigidly, G_k = G_{i(k)} ⊕ (L_{i(k)}⁻¹ ⊕ L_k). Each L_k comes from matching scan k against the map, so two
neighbouring scans carry two independent map-match errors (≈ 1 cm on the real logs), while registering the raw
scans onto each other is several millimetres closer to the logs' relations (research/notebook/2026-11-23-kummerle2009.md). The refinement
solves, by batch Levenberg-Marquardt from G_k, for X_k (world pose of every scan k from the first node's scan k_0
on, Pose2):

    nodes     X_{k_i} = G_i for every node i (tight priors: the graph's global structure, loops included, is kept)
    hanging   X_{i(k)}⁻¹ X_k = L_{i(k)}⁻¹ ⊕ L_k  for every scan k that is not a node, with the front end's
              covariance rule of a sequential factor: R_kᵀ C_k R_k + diag(σ_t², σ_t², σ_θ²) (R_k: L_k's rotation)
    pairwise  X_a⁻¹ X_k = z_ak for a = k − 1 … k − m: scan k's end points registered onto scan a's by point-to-line
              ICP (:mod:`~slamarena.mapping.scan_matching.point_to_line`) from L_a⁻¹ ⊕ L_k, with the ICP's Laplace
              covariance rotated into scan k's frame (z's end, where GTSAM measures the error) plus
              diag(ρ_t², ρ_t², ρ_θ²), robustified as the loops are; where scan k's geometry does not constrain a
              direction (the front end's degeneracy test), z keeps the front end's relative pose along it and
              states no information there, so the hanging factor (the odometry) places the scan along a corridor
              (``LaserSLAM._pairwise_kept``)

With the nodes fixed the problem splits into the runs of scans between consecutive nodes, each tied to the node
before it (hanging) and, through the pairwise chain, to the nodes on either side. The nodes are held because
letting the pairwise chain move them bends the map: on the simulated loop of the tests the ATE rose from 0.036 to
0.066 m, on Intel the revisit relations (≥ 600 s apart) from 2.7 to 2.8 cm (3.5 cm with m = 2): the chain of ICP
factors is stiffer than its true error, and the robust loop factors yield to it (research/notebook/2026-11-23-kummerle2009.md).
Without pairwise factors the hanging factors have zero residual at G_k, which is then the optimum. A non-finite
or increasing error is an :class:`~.backend.OptimizationError`. Parameters: :class:`RefineParams` (m =
``neighbours``, ρ = ``sigma_*``), the ``refine`` of laser graph SLAM's parameters.
"""

from __future__ import annotations

import numpy as np
from pydantic import NonNegativeInt, PositiveFloat

from slamarena.datasets.geometry import between, compose
from slamarena.params import Field, Params
from slamarena.robust import RobustKernelParams, noise_model

from ..scan_matching.point_to_line import PointToLineICPMatcherParams
from .backend import batch_optimise

__all__ = ["RefineParams", "refine_scans"]


class RefineParams(Params):
    """The local refinement (module docstring): which scans are registered onto which, and the pairwise factors."""

    neighbours: NonNegativeInt = Field(
        2, description="register each scan onto this many preceding scans, m (0: no refinement)"
    )
    max_range: PositiveFloat = Field(20.0, description="the refinement's ICP uses the end points within this range [m]")
    min_paired: float = Field(
        0.5,
        gt=0.0,
        le=1.0,
        description="a pairwise registration is used when at least this fraction of the scan's points is paired",
    )
    sigma_translation: PositiveFloat = Field(0.005, description="added to a pairwise factor's translation σ, ρ_t [m]")
    sigma_rotation: PositiveFloat = Field(0.002, description="added to a pairwise factor's rotation σ, ρ_θ [rad]")
    matcher: PointToLineICPMatcherParams = Field(
        PointToLineICPMatcherParams(), description="the refinement's point-to-line ICP"
    )


def refine_scans(
    initial: np.ndarray,
    node_scan: np.ndarray,
    hanging: list,
    pairs: list,
    kernel: RobustKernelParams,
    prior_sigma: float = 1e-6,
    max_iterations: int = 100,
) -> tuple[np.ndarray, dict]:
    """Refined world poses (K, 3) of every scan from ``initial`` (K, 3; the nodes' scans ``node_scan`` keep their
    poses, scans before ``node_scan[0]`` follow the first node rigidly) and a report.

    ``hanging`` and ``pairs``: (a, k, z, Σ) between scan indices (module docstring; pairs robustified with ``kernel``).
    """
    import gtsam

    k0 = int(node_scan[0])
    K = len(initial)
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    for k in range(k0, K):
        values.insert(k, gtsam.Pose2(*initial[k]))
    for k in node_scan:
        graph.add(
            gtsam.PriorFactorPose2(int(k), gtsam.Pose2(*initial[k]), gtsam.noiseModel.Isotropic.Sigma(3, prior_sigma))
        )
    for a, k, z, cov in hanging:
        graph.add(gtsam.BetweenFactorPose2(a, k, gtsam.Pose2(*z), noise_model(cov)))
    for a, k, z, cov in pairs:
        graph.add(gtsam.BetweenFactorPose2(a, k, gtsam.Pose2(*z), noise_model(cov, kernel)))
    result, report = batch_optimise(graph, values, max_iterations, "the local refinement")
    poses = initial.copy()
    poses[k0:] = gtsam.utilities.extractPose2(result)
    poses[:k0] = compose(poses[k0], between(initial[k0], initial[:k0]))
    return poses, {**report, "pairs": len(pairs), "variables": K - k0}
