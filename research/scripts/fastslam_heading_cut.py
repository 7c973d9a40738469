"""The particles' heading about Vicon when FastSLAM is stopped at given times (research/notebook/2026-11-28-fastslam-depletion.md §2).

    python research/scripts/fastslam_heading_cut.py SEED M '{"param": value}' T [T ...]

Runs the mrclam config's ``fastslam`` row on MRCLAM Dataset 6 robot 4 (JSON added to its parameters, M particles,
filter seed SEED) on the sequence cut at T seconds after its first observation, and prints the particles' heading error
against the interpolated Vicon pose at the last update (weighted mean, sd, min, max [deg]), their mean position error,
N_eff and the resamplings so far.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace

import numpy as np

import slamarena
from slamarena.datasets.geometry import interpolate_poses

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from fastslam_depletion import reference  # noqa: E402


def main() -> None:
    seed, M, extra, cuts = int(sys.argv[1]), int(sys.argv[2]), json.loads(sys.argv[3]), [float(c) for c in sys.argv[4:]]
    seq, params, t_ref, p_ref, _ = reference("mrclam6:4")
    first = seq.range_bearing.t[0]
    for cut in cuts:
        end = first + cut
        part = replace(
            seq,
            motion=seq.motion.select(seq.motion.t <= end),
            range_bearing=seq.range_bearing.select(seq.range_bearing.t <= end),
        )
        f = slamarena.create("fastslam", **{**params, "seed": seed, "particles": M, **extra})
        f.run(part)
        ref = interpolate_poses(t_ref, p_ref, np.array([f._t]))[0]
        w = f.weights
        dth = np.degrees(np.angle(np.exp(1j * (f.x0[:, 2] - ref[2]))))
        dxy = np.hypot(*(f.x0[:, :2] - ref[:2]).T)
        mean = w @ dth
        print(
            f"cut {cut:5.1f} s (last update {f._t - first:5.1f} s): heading error {mean:6.1f} ± {np.sqrt(w @ (dth - mean) ** 2):4.1f}° "
            f"(min {dth.min():6.1f}, max {dth.max():6.1f}); position error {w @ dxy:.2f} m; N_eff {f.n_eff:.1f}, "
            f"{f.resamplings} resamplings"
        )


if __name__ == "__main__":
    main()
