"""Landmark extraction from raw scans (mapping/landmark_extraction.py) on the ``sim:laser`` pole field, whose poles are
known: detection rate, false detections, and range/bearing errors against the stated covariance; the robot-frame
transform against finite differences. Real scans: tests/datasets/test_formats_carpark.py (the car park's beacons)."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena import datasets
from slamarena.datasets.geometry import compose, wrap_angle
from slamarena.datasets.sequence import Scans
from slamarena.datasets.sim import laser
from slamarena.mapping.landmark_extraction import ExtractionParams, extract, landmark_sequence, to_robot_frame

#: the detection range the tests ask for [m] (the extractor's default max_range)
RANGE = 30.0


@pytest.fixture(scope="module")
def field():
    """One lap of the pole field: a SICK-like scanner (180°, 361 beams, 2 cm range noise), 1 m/s, and for every scan
    the true sensor pose and, per beam, the object its ray meets first (pole index, −1 a wall) and its true range."""
    seq = datasets.load(
        "sim:laser", world="poles", fov=np.pi, n_beams=361, max_range=40.0, sigma_range=0.02, speed=1.0, seed=1
    )
    sc, gt = seq.scans, seq.ground_truth
    sensor = compose(gt.poses[np.searchsorted(gt.t, sc.t)], sc.mount)
    poles = np.asarray(laser.WORLDS["poles"].poles, dtype=float)
    directions = sensor[:, 2:3] + sc.angles[None, :]
    to_wall = laser.raycast(sensor[:, :2], directions, laser.segments("poles"))
    to_pole, pole = laser.raycast_poles(sensor[:, :2], directions, poles)
    return seq, sensor, poles, np.where(to_pole < to_wall, pole, -1), np.minimum(to_pole, to_wall)


def _visible(field, kinds, min_beams) -> np.ndarray:
    """(S, P) the poles a scan shows whole: of the asked kinds, centre within RANGE, at least ``min_beams`` beams on
    it in one run, and both beams beside the run meeting something farther (not partly hidden, not cut by the fov)."""
    seq, sensor, poles, hit, true_range = field
    S, B = hit.shape
    rows = np.arange(S)
    out = np.zeros((S, len(poles)), dtype=bool)
    for k in np.flatnonzero(kinds):
        on = hit == k
        n = on.sum(axis=1)
        first, last = np.argmax(on, axis=1), B - 1 - np.argmax(on[:, ::-1], axis=1)
        distance = np.hypot(*(poles[k, :2] - sensor[:, :2]).T)
        inside = (first > 0) & (last < B - 1)
        before, after = np.clip(first - 1, 0, B - 1), np.clip(last + 1, 0, B - 1)
        clear = (true_range[rows, before] > distance) & (true_range[rows, after] > distance)
        out[:, k] = (n >= min_beams) & (n == last - first + 1) & inside & clear & (distance <= RANGE)
    return out


def _score(field, det, kinds, visible):
    """Detected fraction of the visible poles, false fraction of the detections, normalised range/bearing errors."""
    seq, sensor, poles, *_ = field
    pose = sensor[det.scan]
    xy = pose[:, :2] + det.range[:, None] * np.column_stack(
        [np.cos(pose[:, 2] + det.bearing), np.sin(pose[:, 2] + det.bearing)]
    )
    distance = np.hypot(xy[:, 0, None] - poles[:, 0], xy[:, 1, None] - poles[:, 1])
    j = distance.argmin(axis=1)
    true = (distance[np.arange(len(j)), j] < 0.5) & kinds[j]
    found = np.zeros_like(visible)
    found[det.scan[true], j[true]] = True
    d = poles[j[true], :2] - pose[true, :2]
    range_error = det.range[true] - np.hypot(d[:, 0], d[:, 1])
    bearing_error = wrap_angle(det.bearing[true] - (np.arctan2(d[:, 1], d[:, 0]) - pose[true, 2]))
    z = np.column_stack([range_error / np.sqrt(det.cov[true, 0, 0]), bearing_error / np.sqrt(det.cov[true, 1, 1])])
    return (found & visible).sum() / visible.sum(), 1.0 - true.mean(), z


@pytest.mark.parametrize(
    "features, kinds, params",
    [
        ("poles", "all", dict(min_beams=2)),  # every pole, beacons included (a beacon is a thin pole)
        ("beacons", "reflective", dict(beacon_radius=0.05)),  # the world's beacons have radius 0.05 m
    ],
)
def test_detects_the_visible_poles_with_the_stated_covariance(field, features, kinds, params):
    seq, sensor, poles, *_ = field
    kinds = np.ones(len(poles), bool) if kinds == "all" else poles[:, 3] > 0
    det = extract(seq.scans, features=features, sigma_range=0.02, max_range=RANGE, **params)
    visible = _visible(field, kinds, params.get("min_beams", 1))
    assert visible.sum() > 1000  # the lap shows each kind often enough to measure 1 %
    detected, false, z = _score(field, det, kinds, visible)
    assert detected >= 0.95, f"{features}: detected {detected:.3f} of the visible ones"
    assert false <= 0.01, f"{features}: {false:.3%} of the detections are not a pole of the kind"
    # errors within the stated σ: RMS of the normalised errors ≤ 1.3 per component (measured 1.13/0.87 poles,
    # 1.18/0.74 beacons), no bias beyond 0.3 σ, and 97 % within 3 σ (the quantisation errors are bounded, not Gaussian)
    rms = np.sqrt(np.mean(z**2, axis=0))
    assert np.all(rms <= 1.3), f"{features}: RMS normalised (range, bearing) error {rms}"
    assert np.all(np.abs(z.mean(axis=0)) <= 0.3), f"{features}: mean normalised error {z.mean(axis=0)}"
    assert np.all(np.mean(np.abs(z) < 3, axis=0) >= 0.97)


def test_pole_diameters_and_the_range_dependent_covariance(field):
    seq, sensor, poles, *_ = field
    det = extract(seq.scans, features="poles", min_beams=2, sigma_range=0.02)
    pose = sensor[det.scan]
    xy = pose[:, :2] + det.range[:, None] * np.column_stack(
        [np.cos(pose[:, 2] + det.bearing), np.sin(pose[:, 2] + det.bearing)]
    )
    j = np.hypot(xy[:, 0, None] - poles[:, 0], xy[:, 1, None] - poles[:, 1]).argmin(axis=1)
    near = det.range < 8.0  # many beams on a pole: the diameter within 0.1 m
    assert np.median(np.abs(det.diameter[near] - 2 * poles[j[near], 2])) < 0.05
    # σ_r grows with the range (the diameter's quantisation), σ_b does not
    far = det.range > 20.0
    assert np.median(det.cov[far, 0, 0]) > 4 * np.median(det.cov[near, 0, 0])
    assert np.median(det.cov[far, 1, 1]) <= np.median(det.cov[near, 1, 1]) * 2.01


def test_robot_frame_matches_geometry_and_finite_differences():
    rng = np.random.default_rng(4)
    r, b = rng.uniform(1, 20, 50), rng.uniform(-1.5, 1.5, 50)
    cov = np.broadcast_to(np.diag([0.02**2, 0.004**2]), (50, 2, 2))
    mount = np.array([3.78, 0.5, -0.016])
    r2, b2, cov2 = to_robot_frame(r, b, cov, mount)
    point = compose(np.broadcast_to(mount, (50, 3)), np.column_stack([r * np.cos(b), r * np.sin(b), np.zeros(50)]))
    assert np.allclose(r2, np.hypot(point[:, 0], point[:, 1])) and np.allclose(b2, np.arctan2(point[:, 1], point[:, 0]))
    eps = 1e-6
    J = np.empty((50, 2, 2))
    for i, (dr, db) in enumerate(((eps, 0), (0, eps))):
        rp, bp, _ = to_robot_frame(r + dr, b + db, cov, mount)
        rm, bm, _ = to_robot_frame(r - dr, b - db, cov, mount)
        J[:, :, i] = np.column_stack([rp - rm, wrap_angle(bp - bm)]) / (2 * eps)
    assert np.allclose(cov2, J @ cov @ np.swapaxes(J, 1, 2), rtol=1e-5, atol=1e-14)


def test_landmark_sequence_replaces_the_observations_and_states_their_noise(field):
    seq = field[0]
    out = landmark_sequence(seq, ExtractionParams(features="beacons", beacon_radius=0.05))
    rb = out.range_bearing
    assert len(rb) == out.meta["extracted"] > 0 and np.all(rb.landmark_id == -1)
    assert out.meta["range_bearing_cov_per_observation"].shape == (len(rb), 2, 2)
    assert out.noise.range_bearing_cov.shape == (2, 2) and out.scans is seq.scans


def test_bad_input_is_refused(field):
    seq = field[0]
    no_intensity = datasets.load("sim:laser", world="loop", n_beams=31, seed=0)
    with pytest.raises(ValueError, match="intensities"):
        extract(no_intensity.scans, features="beacons")
    with pytest.raises(ValueError, match="min_range"):
        ExtractionParams(min_range=40.0, max_range=30.0)
    with pytest.raises(ValueError, match="no scans"):
        landmark_sequence(datasets.load("sim:landmarks", n_landmarks=5, seed=0))
    assert len(extract(seq.scans.select(slice(0, 0)), features="poles")) == 0


def test_a_beacon_whose_reflection_drops_out_on_a_beam_is_one_detection():
    """The car park's scan 521 (t = 156.388 s): beams 17 and 20 bright at 2.42 and 2.40 m, beam 18 dark at 2.37 m and
    beam 19 a no-return between them."""
    ranges = np.full((1, 41), 81.91)
    ranges[0, 15:23] = [2.48, 81.87, 2.42, 2.37, 81.87, 2.40, 81.87, 2.43]
    intensities = np.zeros((1, 41))
    intensities[0, [17, 20]] = 4.0
    scans = Scans(
        t=[0.0], ranges=ranges, angles=np.radians(np.arange(41) * 0.5 - 10.0), max_range=80.0, intensities=intensities
    )
    one = extract(scans, features="beacons")
    assert len(one) == 1 and one.beams[0] == 4 and np.isclose(one.range[0], 2.41)
    assert np.isclose(one.bearing[0], np.radians(18.5 * 0.5 - 10.0))
    assert len(extract(scans, features="beacons", bridge=0)) == 2
    ranges[0, 20] = 3.5  # across a range step it is two objects
    assert (
        len(
            extract(
                Scans(t=[0.0], ranges=ranges, angles=scans.angles, max_range=80.0, intensities=intensities),
                features="beacons",
            )
        )
        == 2
    )
