"""sim:landmarks — determinism, noise statistics, sensor limits, truth vs controls, closure, scaling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from checks import assert_dead_reckoning_consistent, assert_gaussian, assert_rejected_naming

from slamarena import datasets
from slamarena.datasets.geometry import wrap_angle
from slamarena.datasets.sim.landmarks import LAYOUTS, LandmarkWorldParams, route_distance, simulate
from slamarena.estimators.models import MOTION_MODELS, observe


def true_controls(seq) -> tuple[np.ndarray, np.ndarray]:
    """(v, ω) recovered from consecutive true poses by inverting the arc step."""
    gt = seq.ground_truth.poses
    dt = seq.motion.dt
    phi = wrap_angle(np.diff(gt[:, 2]))
    chord = np.hypot(*np.diff(gt[:, :2], axis=0).T)
    return chord / (dt * np.sinc(phi / 2 / np.pi)), phi / dt


@pytest.fixture(scope="module")
def seq():
    return simulate(seed=7, laps=2)


def test_determinism_per_seed():
    a, b, c = simulate(seed=3), simulate(seed=3), simulate(seed=4)
    for x, y in (
        (a.motion.v, b.motion.v),
        (a.range_bearing.range, b.range_bearing.range),
        (a.landmarks.xy, b.landmarks.xy),
    ):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a.landmarks.xy, c.landmarks.xy)
    assert not np.array_equal(a.motion.v, c.motion.v)


def test_independent_random_streams():
    a, b = simulate(seed=3), simulate(seed=3, sigma_range=0.5)
    np.testing.assert_array_equal(a.landmarks.xy, b.landmarks.xy)
    np.testing.assert_array_equal(a.motion.omega, b.motion.omega)


def test_registry_and_shapes(seq):
    s = datasets.load("sim:landmarks", n_landmarks=20, seed=1)
    assert len(s.landmarks) == 20 and s.meta["n_landmarks"] == 20
    K = len(seq.motion)
    assert len(seq.ground_truth) == K + 1
    np.testing.assert_allclose(seq.ground_truth.t[:K], seq.motion.t)
    np.testing.assert_allclose(seq.ground_truth.t[-1], seq.motion.t[-1] + seq.motion.dt[-1])
    np.testing.assert_array_equal(seq.initial_pose, seq.ground_truth.poses[0])
    np.testing.assert_allclose(seq.noise.twist_cov, np.diag([0.1**2, 0.05**2]))
    np.testing.assert_allclose(seq.noise.range_bearing_cov, np.diag([0.1**2, math.radians(1) ** 2]))


def test_control_noise_statistics(seq):
    """The control error is N(0, diag(σ_v², σ_ω²)) and white, one draw per row — exactly the filters' motion model
    (Noise.twist_cov per row): its autocorrelation at lags 1–10 and the v–ω cross-correlation are inside ±4/√n."""
    v, w = true_controls(seq)
    ev, ew = seq.motion.v - v, seq.motion.omega - w
    assert_gaussian(ev, 0.1)
    assert_gaussian(ew, 0.05)
    bound = 4.0 / math.sqrt(ev.size)
    for e in (ev, ew):
        e = (e - e.mean()) / e.std()
        assert all(abs(np.mean(e[lag:] * e[:-lag])) < bound for lag in range(1, 11))
    assert abs(np.corrcoef(ev, ew)[0, 1]) < bound


def test_truth_follows_piecewise_constant_true_controls(seq):
    v, w = true_controls(seq)
    pairs = np.unique(np.round(np.column_stack([v, w]), 9), axis=0)
    assert pairs.shape[0] == 2  # straight (speed, 0) and turn (ω r, ω)
    straight, turn = pairs[np.argsort(np.abs(pairs[:, 1]))]
    np.testing.assert_allclose(straight, [1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(turn[0] / turn[1], seq.meta["route"]["turn_radius"], rtol=1e-7)
    # the truth is exactly the motion model driven by those controls
    again = MOTION_MODELS["arc"].integrate(seq.initial_pose, v, w, seq.motion.dt)
    np.testing.assert_allclose(again, seq.ground_truth.poses, atol=1e-9)


def test_stated_control_noise_makes_dead_reckoning_consistent():
    """Monte Carlo NEES of the final pose of dead reckoning with Noise.twist_cov: inside the χ² band."""
    assert_dead_reckoning_consistent(simulate(seed=seed, n_landmarks=10) for seed in range(30))


@pytest.mark.parametrize("model", sorted(MOTION_MODELS))
def test_loop_closes_every_lap(model):
    s = simulate(seed=0, laps=3, motion_model=model)
    per_lap = s.meta["route"]["steps_per_lap"]
    gt = s.ground_truth.poses
    for lap in range(4):
        np.testing.assert_allclose(gt[lap * per_lap], gt[0], atol=1e-9)


def test_observation_noise_statistics(seq):
    rb = seq.range_bearing
    k = np.searchsorted(seq.ground_truth.t, rb.t)
    np.testing.assert_allclose(seq.ground_truth.t[k], rb.t)  # stamped at truth times …
    assert k.min() >= 1  # … after a motion step, never at t0
    h = observe(seq.ground_truth.poses[k], seq.landmarks.xy[rb.landmark_id])
    assert_gaussian(rb.range - h[:, 0], 0.1)
    assert_gaussian(wrap_angle(rb.bearing - h[:, 1]), math.radians(1))
    assert np.all(np.abs(rb.bearing) <= np.pi)


@pytest.mark.parametrize("fov,max_range", [(math.pi, 10.0), (math.radians(60), 6.0), (2 * math.pi, 4.0)])
def test_fov_and_range_respected_and_complete(fov, max_range):
    s = simulate(seed=2, fov=fov, max_range=max_range, sigma_range=0.0, sigma_bearing=0.0)
    rb, gt = s.range_bearing, s.ground_truth
    assert rb.range.max() <= max_range and np.abs(rb.bearing).max() <= fov / 2
    for k in (1, 100, 333, len(gt) - 1):  # brute force: exactly the landmarks in view
        r, b = observe(gt.poses[k], s.landmarks.xy).T
        expected = np.flatnonzero((r <= max_range) & (np.abs(b) <= fov / 2))
        got = rb.landmark_id[rb.t == gt.t[k]]
        assert sorted(got) == sorted(expected)
        np.testing.assert_allclose(rb.range[rb.t == gt.t[k]], np.sort(r[expected]))  # nearest first


def test_max_observations_keeps_the_nearest():
    full = simulate(seed=5, sigma_range=0.0)
    capped = simulate(seed=5, sigma_range=0.0, max_observations=3)
    counts = np.unique(capped.range_bearing.t, return_counts=True)[1]
    assert counts.max() == 3
    for t in np.unique(full.range_bearing.t)[::50]:
        f = full.range_bearing.landmark_id[full.range_bearing.t == t][:3]
        np.testing.assert_array_equal(capped.range_bearing.landmark_id[capped.range_bearing.t == t], f)


def test_random_choice_observes_every_landmark_the_nearest_hide():
    """The scaling study's world: ten observations a step; the nearest ten never show the band's far side."""
    kw = dict(seed=2, n_landmarks=400, density=0.5, max_observations=10)
    nearest, chosen = simulate(**kw), simulate(**kw, observation_choice="random")
    assert np.unique(nearest.range_bearing.landmark_id).size < 0.6 * 400
    assert np.unique(chosen.range_bearing.landmark_id).size == 400
    np.testing.assert_array_equal(nearest.range_bearing.t, chosen.range_bearing.t)  # ten rows at every step either way
    # a chosen row is a visible landmark, observed where it is, nearest first within a set
    truth = chosen.ground_truth.poses[np.searchsorted(chosen.ground_truth.t, chosen.range_bearing.t)]
    xy = chosen.landmarks.xy[chosen.range_bearing.landmark_id]  # ids are 0 … n − 1
    true_range = np.hypot(*(xy - truth[:, :2]).T)
    assert true_range.max() <= 10.0
    np.testing.assert_allclose(chosen.range_bearing.range, true_range, atol=6 * 0.1)
    same_t = chosen.range_bearing.t[1:] == chosen.range_bearing.t[:-1]
    assert np.all(np.diff(true_range)[same_t] >= 0)
    np.testing.assert_array_equal(nearest.motion.v, chosen.motion.v)  # the other streams are unchanged
    np.testing.assert_array_equal(nearest.landmarks.xy, chosen.landmarks.xy)
    again = simulate(**kw, observation_choice="random")
    np.testing.assert_array_equal(again.range_bearing.landmark_id, chosen.range_bearing.landmark_id)


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_layouts_lie_in_the_band(layout):
    s = simulate(n_landmarks=120, layout=layout, seed=1)
    assert len(s.landmarks) == 120
    r = s.meta["route"]
    d = route_distance(s.landmarks.xy, r["half_a"], r["half_b"], r["turn_radius"])
    assert d.min() >= 1.0 - 1e-9 and d.max() <= 8.0 + 1e-9
    assert np.unique(s.landmarks.xy, axis=0).shape[0] == 120


def test_world_scales_with_density():
    small, big = simulate(n_landmarks=100), simulate(n_landmarks=400)
    assert big.meta["route"]["length"] == pytest.approx(4 * small.meta["route"]["length"], rel=0.05)


def test_scales_to_2000_landmarks_with_capped_observations():
    s = simulate(n_landmarks=2000, density=0.1, speed=5.0, max_observations=10, seed=0)
    counts = np.unique(s.range_bearing.t, return_counts=True)[1]
    assert counts.max() == 10
    assert np.unique(s.range_bearing.landmark_id).size > 0.95 * 2000


def test_events_predict_then_update(seq):
    ev = list(seq.events())[:4]
    assert [e.stream for e in ev] == ["motion", "motion", "range_bearing", "motion"]
    assert ev[1].t == ev[2].t == seq.ground_truth.t[1]


@pytest.mark.parametrize(
    "bad",
    [
        dict(layout="spiral"),
        dict(motion_model="rk4"),
        dict(dt=0.0),
        dict(n_landmarks=0),
        dict(n_landmarks=-5),
        dict(clearance=9.0),
        dict(clearance=8.0),
        dict(sigma_v=-1.0),
        dict(max_observations=0),
        dict(density=float("nan")),
        dict(density=float("inf")),
        dict(fov=7.0),
        dict(seed=-1),
        dict(n_landmark=5),
        dict(n_landmarks=10**12),  # a world beyond the memory available (an empty MemoryError in the cell)
        dict(laps=10**12),
    ],
)
def test_bad_config_is_rejected_naming_the_field(bad):
    assert_rejected_naming(simulate, **bad)


def test_a_params_model_and_keywords_simulate_alike():
    given = simulate(params=LandmarkWorldParams(n_landmarks=12, layout="grid", seed=2))
    keywords = datasets.load("sim:landmarks", n_landmarks=12, layout="grid", seed=2)
    assert simulate.Params is LandmarkWorldParams and given.meta == keywords.meta and given.meta["layout"] == "grid"
    np.testing.assert_array_equal(given.range_bearing.range, keywords.range_bearing.range)
