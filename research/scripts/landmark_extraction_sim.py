"""Landmark extraction on ``sim:laser``'s pole field (research/method/landmark_extraction.md): detected fraction of the
visible poles, false detections, normalised range/bearing errors by kind, and the range error by beam count — the
numbers of the method page's table (the test asserts their bounds: tests/mapping/test_landmark_extraction.py).

    python research/scripts/landmark_extraction_sim.py
"""

from __future__ import annotations

import numpy as np

from slamarena import datasets
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sim import laser
from slamarena.mapping.landmark_extraction import extract

RANGE = 30.0


def main() -> None:
    seq = datasets.load(
        "sim:laser", world="poles", fov=np.pi, n_beams=361, max_range=40.0, sigma_range=0.02, speed=1.0, seed=1
    )
    sc, gt = seq.scans, seq.ground_truth
    sensor = compose(gt.poses[np.searchsorted(gt.t, sc.t)], sc.mount)
    poles = np.asarray(laser.WORLDS["poles"].poles, dtype=float)
    directions = sensor[:, 2:3] + sc.angles[None, :]
    to_wall = laser.raycast(sensor[:, :2], directions, laser.segments("poles"))
    to_pole, pole = laser.raycast_poles(sensor[:, :2], directions, poles)
    hit, true_range = np.where(to_pole < to_wall, pole, -1), np.minimum(to_pole, to_wall)
    S, B = hit.shape
    rows = np.arange(S)
    for features, params in (("poles", dict(min_beams=2)), ("beacons", dict(beacon_radius=0.05))):
        kinds = np.ones(len(poles), bool) if features == "poles" else poles[:, 3] > 0
        visible = np.zeros((S, len(poles)), dtype=bool)
        for k in np.flatnonzero(kinds):
            on = hit == k
            n = on.sum(axis=1)
            first, last = np.argmax(on, axis=1), B - 1 - np.argmax(on[:, ::-1], axis=1)
            distance = np.hypot(*(poles[k, :2] - sensor[:, :2]).T)
            clear = (true_range[rows, np.clip(first - 1, 0, B - 1)] > distance) & (
                true_range[rows, np.clip(last + 1, 0, B - 1)] > distance
            )
            inside = (first > 0) & (last < B - 1)
            visible[:, k] = (
                (n >= params.get("min_beams", 1)) & (n == last - first + 1) & inside & clear & (distance <= RANGE)
            )
        det = extract(sc, features=features, sigma_range=0.02, max_range=RANGE, **params)
        pose = sensor[det.scan]
        angle = pose[:, 2] + det.bearing
        xy = pose[:, :2] + det.range[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
        d = np.hypot(xy[:, 0, None] - poles[:, 0], xy[:, 1, None] - poles[:, 1])
        j = d.argmin(axis=1)
        true = (d[np.arange(len(j)), j] < 0.5) & kinds[j]
        found = np.zeros_like(visible)
        found[det.scan[true], j[true]] = True
        rel = poles[j[true], :2] - pose[true, :2]
        er = det.range[true] - np.hypot(rel[:, 0], rel[:, 1])
        eb = wrap_angle(det.bearing[true] - (np.arctan2(rel[:, 1], rel[:, 0]) - pose[true, 2]))
        z = np.column_stack([er / np.sqrt(det.cov[true, 0, 0]), eb / np.sqrt(det.cov[true, 1, 1])])
        print(
            f"{features}: {visible.sum()} visible (scan, pole) pairs, {len(det)} detections; detected "
            f"{(found & visible).sum() / visible.sum():.4f}, false {1 - true.mean():.5f} ({(~true).sum()}); RMS z "
            f"(range, bearing) {np.sqrt(np.mean(z**2, axis=0)).round(3)}, mean z {z.mean(axis=0).round(3)}, within 3σ "
            f"{np.mean(np.abs(z) < 3, axis=0).round(4)}; range error mean {er.mean() * 100:.2f} cm"
        )
        for n in range(1, 8):
            pick = det.beams[true] == n
            if pick.sum():
                print(
                    f"    {n} beams: {pick.sum()} rows at {det.range[true][pick].mean():.1f} m mean range, range error "
                    f"{er[pick].mean() * 100:+.2f} cm, RMS z_r {np.sqrt(np.mean(z[pick, 0] ** 2)):.2f}"
                )


if __name__ == "__main__":
    main()
