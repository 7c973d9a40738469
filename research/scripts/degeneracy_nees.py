"""NEES of laser graph SLAM's sequential factors against the simulated truth (research/notebook/2026-11-28-degeneracy-2.md).

Usage: ``python research/scripts/degeneracy_nees.py WORLD TAU [SEED] [NOISE]`` with WORLD a ``sim:laser`` world, TAU the
front end's ``degeneracy_threshold`` and NOISE ``interval`` (``odometry_noise`` at its defaults: the odometry accumulated
over the interval, fused with the match) or ``match`` (the default ``odometry_noise: None``, the match's covariance). Prints the mean NEES
eᵀΣ⁻¹e (dof 3) of the sequential factors, e = Log(z⁻¹ T_{i−1}⁻¹ T_i) at the true poses, the fraction inside χ²₃'s
central 95 %, the mean 1-dof NEES along the world's x axis in the factor frame, the ATE and the CPU time.
"""

from __future__ import annotations

import sys
import time

import numpy as np


def sequential_nees(est, graph, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per sequential factor: the 3-dof NEES and the error vector e (3,) in the factor's end frame."""
    import gtsam

    nodes = est.diagnostics["node_scan"]
    seq = (graph.edge_j == graph.edge_i + 1) & (np.arange(len(graph.edge_i)) < len(nodes) - 1)
    nees, errors = [], []
    for i, j, z, info in zip(graph.edge_i[seq], graph.edge_j[seq], graph.edge_z[seq], graph.edge_information[seq]):
        a, b = gtsam.Pose2(*truth[nodes[i]]), gtsam.Pose2(*truth[nodes[j]])
        e = gtsam.Pose2.Logmap(gtsam.Pose2(*z).inverse().compose(a.inverse().compose(b)))
        nees.append(float(e @ info @ e))
        errors.append(e)
    return np.asarray(nees), np.asarray(errors)


def main(argv: list[str]) -> None:
    from scipy.stats import chi2

    from slamarena.datasets.sim.laser import simulate
    from slamarena.mapping.laser_slam.slam import LaserSLAM

    world, tau = argv[0], float(argv[1])
    seed = int(argv[2]) if len(argv) > 2 else 0
    noise = argv[3] if len(argv) > 3 else "interval"
    seq = simulate(world=world, seed=seed)
    params = {"frontend": {"matcher_params": {"degeneracy_threshold": tau}}}
    if noise == "interval":
        params["odometry_noise"] = {}
    slam = LaserSLAM(**params)
    cpu = time.process_time()
    est = slam.run(seq)
    cpu = time.process_time() - cpu
    gt = seq.ground_truth
    truth = gt.poses[np.searchsorted(gt.t, seq.scans.t)]
    nees, _ = sequential_nees(est, slam.pose_graph, truth)
    lo, hi = chi2.ppf([0.025, 0.975], 3)
    ate = float(np.sqrt(np.mean(np.sum((est.poses[:, :2] - truth[:, :2]) ** 2, axis=1))))
    print(
        f"{world} seed={seed} tau={tau:g} noise={noise}: {len(nees)} factors, mean NEES {nees.mean():.2f} (dof 3), "
        f"median {np.median(nees):.2f}, inside chi2_3 95% {np.mean((nees >= lo) & (nees <= hi)):.2f}, "
        f"above {np.mean(nees > hi):.2f}; loops {est.meta['loop_closures']}; ATE {ate:.3f} m (no alignment); "
        f"cpu {cpu:.0f} s"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
