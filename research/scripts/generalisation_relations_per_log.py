"""notebook/2026-11-28-generalisation.md: the reference relations of each SLAM-corrected log (metric ``refrel``).

Run from the repository root: ``python research/scripts/generalisation_relations_per_log.py``. Per log: scans, the
reference path, local and loop relations, the median span of the loop relations in scans, and the loop pairs the
position test proposed but the overlap test refused.
"""

import warnings

import numpy as np

from slamarena import datasets
from slamarena.datasets.catalogue import CATALOGUE
from slamarena.experiments.metrics.reference_relations import ReferenceRelationsParams, reference_relations
from slamarena.experiments.metrics.relations import revisit_relations


def main() -> None:
    warnings.simplefilter("ignore")
    p = ReferenceRelationsParams()
    print("| log | scans | path [m] | local | loop | loop span [scans, median] | proposed, refused by overlap |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name in sorted(n for n in CATALOGUE if n.startswith("carmen-corrected:")):
        seq = datasets.load(name)
        x = seq.ground_truth.poses
        rel = reference_relations(seq.scans, x, p)
        proposed = revisit_relations(np.arange(len(x), dtype=float), x, p.radius, p.min_travel, p.stride)[0].size
        path = np.linalg.norm(np.diff(x[:, :2], axis=0), axis=1).sum()
        span = np.median(rel.j[rel.loop] - rel.i[rel.loop]) if rel.loop.any() else float("nan")
        print(
            f"| {name.split(':')[1]} | {len(x)} | {path:.0f} | {(~rel.loop).sum()} | {rel.loop.sum()} | {span:.0f} | "
            f"{proposed} → {proposed - rel.loop.sum()} |"
        )


if __name__ == "__main__":
    main()
