"""Hand-made laser worlds for the mapping tests (independent of the simulators)."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.geometry import accumulate, between
from slamarena.datasets.sequence import Scans, Sequence, Trajectory

# an L-shaped 12 × 10 m room with two pillars: segments (x0, y0, x1, y1)
WALLS = np.array(
    [
        [-6, -5, 6, -5],
        [6, -5, 6, 1],
        [6, 1, 1, 1],
        [1, 1, 1, 5],
        [1, 5, -6, 5],
        [-6, 5, -6, -5],
        [-3, -2, -2, -2],
        [-2, -2, -2, -1],
        [-2, -1, -3, -1],
        [-3, -1, -3, -2],
        [3.5, -1.0, 4.2, -0.3],
        [4.2, -0.3, 3.0, -0.2],
        [3.0, -0.2, 3.5, -1.0],
    ],
    dtype=float,
)  # walls on round coordinates: through cell centres of the maps


def raycast(pose, angles, walls=WALLS, max_range=20.0):
    """Ranges from pose along beam angles to the nearest wall (max_range if none)."""
    th = pose[2] + np.asarray(angles)
    d = np.stack([np.cos(th), np.sin(th)], axis=1)[:, None, :]  # (B, 1, 2)
    p, q = walls[None, :, :2], walls[None, :, 2:]
    e = q - p
    w = p - pose[:2]
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
        u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / den
    ok = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    r = np.where(ok, t, np.inf).min(axis=1)
    return np.minimum(r, max_range)


def make_sequence(n=120, beams=181, sigma=0.01, odo_sigma=(0.02, 0.02, 0.01), seed=0, max_range=20.0):
    """A drive through the room: truth, noisy scans and drifting odometry attached to the scans."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0, 1, n)
    truth = np.column_stack([-4.5 + 8.5 * s, -3.5 + 1.5 * np.sin(np.pi * s), 0.4 * np.cos(2 * np.pi * s)])
    angles = np.linspace(-np.pi / 2, np.pi / 2, beams)
    ranges = np.stack([raycast(p, angles, max_range=max_range) for p in truth])
    noisy = ranges + sigma * rng.standard_normal(ranges.shape)
    noisy[ranges >= max_range] = max_range
    inc = between(truth[:-1], truth[1:]) + rng.standard_normal((n - 1, 3)) * np.array(odo_sigma)
    odom = accumulate(truth[0], inc)
    t = 0.2 * np.arange(n)
    scans = Scans(t=t, ranges=noisy, angles=angles, max_range=max_range, pose=odom)
    return Sequence(name="test:room", scans=scans, ground_truth=Trajectory(t=t, poses=truth), initial_pose=truth[0])


def interlace(seq, layouts: int = 4, sigma: float = 0.01, seed: int = 0) -> Scans:
    """The room drive re-scanned like fr-clinic: scan k starts ``(k mod 4)/4`` of a step later,
    with one beam fewer unless it is the unshifted layout."""
    rng = np.random.default_rng(seed)
    sc, truth = seq.scans, seq.ground_truth.poses
    K, B = sc.ranges.shape
    q = np.arange(K) % layouts
    offset = q * (sc.angles[1] - sc.angles[0]) / layouts
    count = np.where(q == 0, B, B - 1)
    ranges = np.full((K, B), np.nan)
    for k in range(K):
        r = raycast(truth[k], sc.angles[: count[k]] + offset[k], max_range=sc.max_range)
        ranges[k, : count[k]] = np.where(r >= sc.max_range, sc.max_range, r + sigma * rng.standard_normal(r.size))
    return Scans(
        t=sc.t,
        ranges=ranges,
        angles=sc.angles,
        max_range=sc.max_range,
        pose=sc.pose,
        angle_offset=offset,
        beam_count=count,
    )


@pytest.fixture(scope="session")
def room_sequence():
    return make_sequence()
