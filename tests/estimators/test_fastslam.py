"""FastSLAM 1.0 / 2.0: the storage's sharing, the proposal and weights, association, resampling, determinism."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from slamarena import datasets
from slamarena.estimators import create
from slamarena.estimators.dead_reckoning import DeadReckoning
from slamarena.estimators.fastslam import FastSLAM
from slamarena.estimators.fastslam.kernels import predictive_d2, update_particles
from slamarena.estimators.fastslam.storage import FANOUT, LEAF, LandmarkStore, writable
from slamarena.experiments.metrics import reference_of
from slamarena.experiments.metrics.landmarks import MapParams, landmark_error
from slamarena.experiments.metrics.trajectory import ATEParams, ate


def _write(store: LandmarkStore, m: int, slot: int, value: float) -> None:
    store.reserve(slot, 1)
    leaf, off = writable(m, slot, store.depth, *store.kernel_args()[:7], *store.kernel_args()[7:])
    store.leaf_mu[leaf, off] = (value, -value)
    store.leaf_S[leaf, off] = (value, 0.0, value)
    store.leaf_state[leaf, off] = 1
    store.leaf_seen[leaf, off] = int(abs(value)) % 5 + 1  # the tentative rule's per-slot state, written with the rest
    store.leaf_born[leaf, off] = -value


def _read(store: LandmarkStore, n: int) -> np.ndarray:
    """Each slot's written value (NaN: empty), checked against the sightings and birth time written with it."""
    mu, _, state, seen, born = store.gather(n)
    live = state > 0
    np.testing.assert_array_equal(born[live], -mu[live][:, 0])
    np.testing.assert_array_equal(seen[live], np.abs(mu[live][:, 0]).astype(int) % 5 + 1)
    return np.where(live, mu[..., 0], np.nan)


# ---------------------------------------------------------------------------- storage
operations = st.lists(
    st.one_of(
        st.tuples(
            st.just("write"),
            st.integers(0, 5),
            st.integers(0, 3 * FANOUT * LEAF),
            st.floats(-1e3, 1e3, allow_nan=False),
        ),
        st.tuples(st.just("resample"), st.lists(st.integers(0, 5), min_size=6, max_size=6)),
    ),
    max_size=60,
)


@settings(max_examples=60, deadline=None)
@given(operations)
def test_copy_on_write_maps_behave_like_independent_copies(ops):
    """Against a literal model (one dict per particle, deep-copied at resampling): a write to one particle's
    landmark — its mean, covariance, state, sightings and birth time — is never seen by another, whatever the
    sharing, and slots beyond the capacity grow the trees."""
    store = LandmarkStore(6)
    model = [dict() for _ in range(6)]
    top = 0
    for op in ops:
        if op[0] == "write":
            _, m, slot, value = op
            _write(store, m, slot, value)
            model[m][slot] = value
            top = max(top, slot + 1)
        else:
            ancestors = np.array(op[1])
            store.resample(ancestors)
            model = [dict(model[a]) for a in ancestors]
    got = _read(store, top)
    expected = np.full((6, top), np.nan)
    for m, d in enumerate(model):
        for slot, value in d.items():
            expected[m, slot] = value
    np.testing.assert_array_equal(got, expected)


def test_resampling_copies_roots_and_a_write_copies_one_path():
    store = LandmarkStore(4)
    for slot in range(200):
        _write(store, 0, slot, float(slot))
    store.resample(np.zeros(4, dtype=np.int64))  # four copies of particle 0
    inner, leaves = store.live_nodes()
    _write(store, 2, 37, -1.0)
    inner2, leaves2 = store.live_nodes()
    assert leaves2 - leaves == 1 and inner2 - inner == store.depth  # one leaf and the inner nodes on its path
    got = _read(store, 200)
    assert got[2, 37] == -1.0 and np.all(got[[0, 1, 3], 37] == 37.0)
    # dropping every copy but one frees the shared nodes' duplicates: nothing leaks
    for _ in range(50):
        store.resample(np.array([2, 2, 2, 2]))
        _write(store, 1, 5, 1.0)
    assert store.live_nodes()[1] <= leaves + 2 * 4


# ---------------------------------------------------------------------------- filter
def test_one_particle_without_noise_follows_the_motion_model():
    seq = datasets.load("sim:landmarks", n_landmarks=10, laps=1, seed=0)
    est = FastSLAM(particles=1, twist_cov=0.0, motion_model="arc").run(seq)
    dr = DeadReckoning(motion_model="arc").run(seq)
    poses = np.array([dr.poses[np.argmin(np.abs(dr.t - t))] for t in est.t])
    matched = np.abs(np.array([dr.t[np.argmin(np.abs(dr.t - t))] for t in est.t]) - est.t) < 1e-9
    np.testing.assert_allclose(est.poses[matched], poses[matched], atol=1e-9)


@pytest.fixture(scope="module")
def small_world():
    return datasets.load("sim:landmarks", n_landmarks=25, laps=1, seed=2)


def test_a_stated_twist_period_makes_the_motion_noise_a_density_of_time():
    """With ``twist_period`` T, a row held for dt carries M·T/dt: a second of motion has the covariance of a second
    whatever its rows (one row of 1 s, 100 of 0.01 s, or 7 rows of unequal length), and rows of period T are applied as
    without it. Without T every row carries M, so one row of 1 s has 100× the heading variance of 100 rows of 0.01 s (the
    irregular MRCLAM odometry: rows of 0.01-1 s)."""
    M, T = np.diag([0.01, 0.04]), 0.02
    cuts = {
        "one": np.array([1.0]),
        "hundred": np.full(100, 0.01),
        "uneven": np.array([0.3, 0.01, 0.19, 0.2, 0.05, 0.05, 0.2]),
    }
    heading = {}
    for per_row in (False, True):
        for name, dt in cuts.items():
            f = FastSLAM(particles=2, twist_cov=M, twist_period=None if per_row else T)
            f.predict_twists(np.zeros(len(dt)), np.zeros(len(dt)), dt)
            heading[per_row, name] = f.Sigma_delta
    for name in cuts:  # the heading variance of 1 s of standing still: density M_ωω T times 1 s
        np.testing.assert_allclose(heading[False, name][2, 2], M[1, 1] * T * 1.0, rtol=1e-12)
    np.testing.assert_allclose(heading[True, "one"][2, 2], 100 * heading[True, "hundred"][2, 2], rtol=1e-12)
    regular = np.full(50, T)
    a, b = FastSLAM(particles=2, twist_cov=M, twist_period=T), FastSLAM(particles=2, twist_cov=M)
    for f in (a, b):
        f.predict_twists(np.full(50, 0.5), np.full(50, 0.2), regular)
    np.testing.assert_allclose(a.Sigma_delta, b.Sigma_delta, rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("version", [1, 2])
def test_known_ids_approach_the_ekf(small_world, version):
    seq = small_world
    ref = reference_of(seq)
    ekf = create("ekf_slam").run(seq)
    fs = FastSLAM(version=version, particles=200, seed=3).run(seq)
    ate_ekf = ate(ekf, ref, ATEParams(align="se2"))[0]["rmse"]
    ate_fs = ate(fs, ref, ATEParams(align="se2"))[0]["rmse"]
    dr = ate(DeadReckoning().run(seq), ref, ATEParams(align="se2"))[0]["rmse"]
    assert ate_fs < 2.0 * ate_ekf and ate_fs < 0.3 * dr, (ate_fs, ate_ekf, dr)
    assert set(fs.landmark_ids) == set(ekf.landmark_ids)
    assert landmark_error(fs, ref, MapParams())[0]["rmse"] < 2.0 * landmark_error(ekf, ref, MapParams())[0]["rmse"]


def test_fastslam2_needs_fewer_resamplings_than_1(small_world):
    one = FastSLAM(version=1, particles=50, seed=1).run(small_world)
    two = FastSLAM(version=2, particles=50, seed=1).run(small_world)
    assert two.meta["resamplings"] < one.meta["resamplings"]
    assert np.median(two.diagnostics["neff"]) > np.median(one.diagnostics["neff"])


@pytest.mark.parametrize("version", [1, 2])
def test_unknown_association_recovers_the_landmarks_of_a_well_separated_map(version):
    seq = datasets.load("sim:landmarks", n_landmarks=16, layout="grid", density=0.02, laps=1, seed=0)
    fs = FastSLAM(version=version, particles=60, use_ids=False, seed=0).run(seq)
    assert len(fs.landmark_ids) == 16, len(fs.landmark_ids)
    err = landmark_error(fs, reference_of(seq), MapParams(by="nearest"))[0]
    assert err["rmse"] < 0.5


def test_existence_counters_remove_a_spurious_landmark():
    f = FastSLAM(particles=5, use_ids=False, max_range=20.0, fov=np.pi, seed=0, range_bearing_cov=[0.01, 1e-4])
    f.update([[5.0, 0.0, -1]])
    f.update([[5.0, 0.0, -1], [4.0, 1.0, -1]])  # a second landmark: seen once
    assert np.all(f.landmark_counts() == 2)
    for _ in range(3):  # then never again, though in view
        f.update([[5.0, 0.0, -1]])
    assert np.all(f.landmark_counts() == 1)


def test_live_counts_follow_new_and_removed_landmarks_through_resampling():
    f = FastSLAM(particles=6, use_ids=False, max_range=20.0, fov=np.pi, seed=1, range_bearing_cov=[0.01, 1e-4])
    rng = np.random.default_rng(4)
    for _ in range(25):
        f.predict([0.3, 0.1], 0.5)
        k = rng.integers(1, 4)
        f.update(np.column_stack([rng.uniform(1.0, 15.0, k), rng.uniform(-1.2, 1.2, k), np.full(k, -1)]))
        f.log_w = rng.normal(size=6)
        f.resample()
        state = f.store.gather(int(f.n_slots.max()))[2]
        np.testing.assert_array_equal(f.landmark_counts(), (state > 0).sum(axis=1))


def test_a_tentative_landmark_is_private_to_its_particle_and_no_evidence_until_confirmed():
    """Two particles sharing one map (after resampling) see the same row: the one whose pose puts it on the shared
    tentative landmark counts a sighting, the other starts a landmark, and neither change is seen by the other particle.
    Both rows weigh the new-landmark likelihood (equal weights). After the window, the landmark confirmed by three
    sightings stays; the other particle's, seen once, is removed — in that particle only."""
    f = FastSLAM(
        particles=2, use_ids=False, confirm_sightings=3, confirm_window=10.0, seed=0, range_bearing_cov=[0.01, 1e-4]
    )
    f.update([[5.0, 0.0, -1]], t=0.0)  # both particles start slot 0
    f.log_w = np.array([0.0, -50.0])
    assert f.resample().tolist() == [0, 0]  # one map, shared
    f.x0[1, 1] += 3.0  # particle 1 stands 3 m to the side: the row is not slot 0 for it
    for t in (1.0, 2.0):
        f.update([[5.0, 0.0, -1]], t=t)
        np.testing.assert_array_equal(f.log_w, 0.0)  # tentative match and new landmark weigh the same
    _, _, state, seen, born = f.store.gather(3)
    np.testing.assert_array_equal(seen[0, :1], [3])  # particle 0: slot 0 seen three times, confirmed
    np.testing.assert_array_equal(seen[1, :2], [1, 2])  # particle 1: slot 0 seen once; its own slot 1 twice
    np.testing.assert_array_equal(born[1, :2], [0.0, 1.0])
    assert f.n_slots.tolist() == [1, 2] and list(f.landmarks(0)[0]) == [0] and len(f.landmarks(1)[0]) == 0
    f.update([[5.0, 1.5, -1]], t=11.5)  # past the window: elsewhere, a new landmark for both
    _, _, state, seen, _ = f.store.gather(3)
    assert state[0, 0] > 0 and state[1, 0] == 0 and state[1, 1] == 0  # particle 1's tentative slots 0 and 1 expired
    np.testing.assert_array_equal(f.landmark_counts(), (state > 0).sum(axis=1))
    assert list(f.landmarks(0)[0]) == [0] and len(f.landmarks(1)[0]) == 0


def test_tentative_landmarks_need_unknown_association():
    with pytest.raises(ValidationError, match="confirm_sightings"):
        FastSLAM(confirm_sightings=3)  # with the ids, the ids decide which landmarks exist
    assert FastSLAM(use_ids=False, confirm_sightings=3).params.confirm_sightings == 3


def test_neff_and_systematic_resampling():
    f = FastSLAM(particles=8, seed=0)
    f.log_w = np.log(np.array([0.5, 0.3, 0.1, 0.1, 1e-9, 1e-9, 1e-9, 1e-9]))
    assert f.n_eff == pytest.approx(1 / (0.25 + 0.09 + 0.01 + 0.01), rel=1e-6)
    ancestors = f.resample()
    counts = np.bincount(ancestors, minlength=8)
    expected = 8 * np.array([0.5, 0.3, 0.1, 0.1, 0, 0, 0, 0])
    assert np.all(np.abs(counts - expected) < 1.0 + 1e-9)  # low variance: within one of M·w
    assert np.all(f.log_w == 0) and f.resamplings == 1


def _common_ancestor_by_walking_back(history, t0):
    """The literal definition: follow every particle's lineage back through the resamplings (t, ancestors) until one
    particle is left."""
    alive = None
    for t, a in reversed(history):
        alive = np.unique(a if alive is None else a[alive])
        if alive.size == 1:
            return t
    return t0


@pytest.mark.parametrize("M", [1, 2, 7, 40])
def test_the_common_ancestor_time_equals_the_walk_back_through_the_ancestry(M):
    """The O(M) recurrence of the neighbours' split times (filter docstring, "Ancestry") against walking every lineage
    back, through 60 resamplings of random weights from flat to one heavy particle; the ancestors are non-decreasing."""
    f = FastSLAM(particles=M, seed=3)
    rng = np.random.default_rng(M)
    history, seen = [], set()
    for k in range(60):
        f.update(np.zeros((0, 3)), t=10.0 + k)  # an empty set at time t: the clock of the next resampling
        f.log_w = rng.normal(0.0, rng.choice([0.1, 1.0, 5.0]), M)
        a = f.resample()
        assert np.all(np.diff(a) >= 0)
        history.append((10.0 + k, a))
        assert f.common_ancestor_t == _common_ancestor_by_walking_back(history, 0.0), k
        seen.add(f.common_ancestor_t)
    assert len(seen) > 5  # the lineages met many times, at different depths


def test_the_run_reports_the_common_ancestor_time(small_world):
    """Non-decreasing, never after the update's own stamp, and the start's time before the first coalescence."""
    est = FastSLAM(particles=30, seed=0).run(small_world)
    d = est.diagnostics
    assert d["common_ancestor_t"].shape == d["neff_t"].shape
    assert np.all(np.diff(d["common_ancestor_t"]) >= 0) and np.all(d["common_ancestor_t"] <= d["neff_t"])
    assert d["common_ancestor_t"][0] == small_world.t0 and d["common_ancestor_t"][-1] > small_world.t0


def test_resampling_happens_below_the_threshold_only(small_world):
    est = FastSLAM(particles=30, resample_threshold=0.5, seed=0).run(small_world)
    d = est.diagnostics
    assert np.all(d["neff"][d["resampled"]] < 0.5 * 30 + 1e-9)
    assert np.all(d["neff"][~d["resampled"]] >= 0.5 * 30 - 1e-9)


def test_same_seed_same_run_and_the_estimate_is_complete(small_world):
    a = FastSLAM(particles=20, seed=5).run(small_world)
    b = FastSLAM(particles=20, seed=5).run(small_world)
    c = FastSLAM(particles=20, seed=6).run(small_world)
    np.testing.assert_array_equal(a.poses, b.poses)
    assert not np.array_equal(a.poses, c.poses)
    assert a.pose_cov.shape == (len(a.t), 3, 3) and np.all(np.linalg.eigvalsh(a.pose_cov) > -1e-12)
    assert np.all(np.diff(a.t) > 0)  # one pose per stamp
    assert a.landmark_cov.shape == (len(a.landmark_ids), 2, 2)
    assert a.diagnostics["best_poses"].shape == a.poses.shape
    best = FastSLAM(particles=20, seed=5, trajectory="best").run(small_world)
    np.testing.assert_array_equal(best.poses, a.diagnostics["best_poses"])


@pytest.mark.parametrize("version", [1, 2])
def test_the_known_landmark_gate_rejects_an_outlier_for_every_particle_and_keeps_true_rows(version):
    """A labelled row 3 m off its landmark (d² ≈ 900 with σ = 0.1 m) is rejected, counted, and changes no particle and no
    weight; without the gate it moves the landmark. True rows pass; a landmark's first row always passes."""

    def filter_(gate):
        f = FastSLAM(
            version=version,
            particles=20,
            seed=1,
            known_confidence=gate,
            range_bearing_cov=[0.01, 1e-4],
            initial_cov=[1e-4, 1e-4, 1e-5],
        )
        f.update([[5.0, 0.0, 7], [4.0, 1.0, 8]])
        return f

    gated, ungated = filter_(0.999), filter_(None)
    _, before, _ = gated.landmarks()
    log_w = gated.log_w.copy()
    gated.update([[8.0, 0.0, 7]])  # 3 m beyond landmark 7
    assert gated.rejected["gate"] == 1
    np.testing.assert_array_equal(gated.landmarks()[1], before)
    np.testing.assert_array_equal(gated.log_w, log_w - log_w.max())
    ungated.update([[8.0, 0.0, 7]])
    assert np.abs(ungated.landmarks()[1][0] - before[0]).max() > 0.1
    gated.update([[5.02, 0.001, 7], [3.98, 1.0, 8], [6.0, -1.0, 9]])  # true rows and a new landmark
    assert gated.rejected["gate"] == 1 and list(gated.landmarks()[0]) == [7, 8, 9]


def test_parameters_are_typed():
    with pytest.raises(ValidationError, match="version"):
        FastSLAM(version=3)
    with pytest.raises(ValidationError, match="particles"):
        FastSLAM(particles=0)
    with pytest.raises(ValidationError, match="particle"):
        FastSLAM(particle=10)
    with pytest.raises(ValidationError, match="fov"):
        FastSLAM(fov=1.0)  # a field of view needs a range
    assert FastSLAM(FastSLAM.Params(particles=7)).params == FastSLAM(particles=7).params


# ---------------------------------------------------------------------------- one update against a literal reference
def _h(x, mu):
    """Range and bearing of landmark mu (2,) from pose x (3,), and their Jacobians H_x (2, 3), H_m (2, 2), literally."""
    d = mu - x[:2]
    q = d @ d
    zhat = np.array([np.sqrt(q), np.arctan2(d[1], d[0]) - x[2]])
    Hm = np.array([[d[0] / np.sqrt(q), d[1] / np.sqrt(q)], [-d[1] / q, d[0] / q]])
    return zhat, np.hstack([-Hm, [[0.0], [-1.0]]]), Hm


def _log_normal(nu, S):
    return -0.5 * nu @ np.linalg.solve(S, nu) - 0.5 * np.log(np.linalg.det(S)) - np.log(2 * np.pi)


def _innovation(z, zhat):
    nu = z - zhat
    nu[1] = (nu[1] + np.pi) % (2 * np.pi) - np.pi
    return nu


def _reference_step(version, xhat, P, mus, Sigmas, z, slots, R, sample):
    """One particle's update, literally (Montemerlo et al. 2003, information form of the 2.0 proposal):
    returns log w, the proposal's mean and covariance, the drawn pose and the landmarks after the update.
    ``sample(mean, cov)`` draws the pose (the caller gives the kernel's draw)."""
    log_w, xbar, Sx = 0.0, xhat.copy(), P.copy()
    if version == 1:
        xbar, Sx = sample(xhat, P), np.zeros((3, 3))
    for zj, s in zip(z, slots):
        if s not in mus:
            continue
        zhat, Hx, Hm = _h(xbar, mus[s])
        Q = Hm @ Sigmas[s] @ Hm.T + R
        nu = _innovation(zj, zhat)
        log_w += _log_normal(nu, Hx @ Sx @ Hx.T + Q)
        if version == 2:
            Sx_new = np.linalg.inv(Hx.T @ np.linalg.inv(Q) @ Hx + np.linalg.inv(Sx))
            xbar = xbar + Sx_new @ Hx.T @ np.linalg.inv(Q) @ nu
            Sx = Sx_new
    x = sample(xbar, Sx) if version == 2 else xbar
    new_mu, new_S = dict(mus), dict(Sigmas)
    for zj, s in zip(z, slots):
        if s in mus:  # the EKF of the landmark at the drawn pose, from its prior
            zhat, _, Hm = _h(x, mus[s])
            Q = Hm @ Sigmas[s] @ Hm.T + R
            K = Sigmas[s] @ Hm.T @ np.linalg.inv(Q)
            new_mu[s] = mus[s] + K @ _innovation(zj, zhat)
            new_S[s] = (np.eye(2) - K @ Hm) @ Sigmas[s]
        else:  # a new landmark, from the drawn pose
            a = x[2] + zj[1]
            G = np.array([[np.cos(a), -zj[0] * np.sin(a)], [np.sin(a), zj[0] * np.cos(a)]])
            new_mu[s] = x[:2] + zj[0] * np.array([np.cos(a), np.sin(a)])
            new_S[s] = G @ R @ G.T
    return log_w, xbar, Sx, x, new_mu, new_S


@pytest.mark.parametrize("version", [1, 2])
def test_one_update_matches_a_literal_reference(version):
    """The compiled kernel against the equations written out per particle in numpy: several observations of mapped
    landmarks (the 2.0 proposal conditioned on them one after the other, each linearised at the moved mean, with the
    information-form covariance) and one of a new landmark between them; the weight, the proposal's mean and covariance
    (the kernel's draws for ε = 0 and the unit vectors give its mean and a square root of its covariance), the drawn
    pose of every particle and every landmark after the update (an unobserved one unchanged)."""
    rng = np.random.default_rng(7)
    xhat = np.array([1.0, -0.5, 0.3])
    B = rng.normal(size=(3, 3)) * [0.3, 0.3, 0.1]
    P = B @ B.T + np.diag([1e-3, 1e-3, 1e-4])  # a large, full-rank prior: the update matters
    R = np.diag([0.1**2, np.radians(2.0) ** 2])
    mus = {0: np.array([4.0, 1.0]), 1: np.array([2.0, 3.5]), 2: np.array([3.0, -2.0]), 3: np.array([-1.0, 2.0])}
    Sigmas = {}
    for s in mus:
        A = rng.normal(size=(2, 2)) * 0.2
        Sigmas[s] = A @ A.T + 0.01 * np.eye(2)
    slots = np.array([1, 4, 0, 3])  # slot 4 is new (≥ n_slots)
    z = np.array([[4.2, 1.1], [3.0, -0.4], [3.1, 0.2], [3.3, 2.0]])
    eps = np.vstack([np.zeros(3), np.eye(3), rng.normal(size=3)])
    M = len(eps)

    store = LandmarkStore(M)
    for m in range(M):
        for s in mus:
            store.reserve(s, 1)
            leaf, off = writable(m, s, store.depth, *store.kernel_args())
            store.leaf_mu[leaf, off] = mus[s]
            store.leaf_S[leaf, off] = (Sigmas[s][0, 0], Sigmas[s][0, 1], Sigmas[s][1, 1])
            store.leaf_state[leaf, off] = 1
    store.reserve(int(slots.max()), M * len(z))
    log_w, n_slots, n_live = np.zeros(M), np.full(M, 4, dtype=np.int64), np.full(M, 4, dtype=np.int64)
    poses, assoc = np.empty((M, 3)), np.empty((M, len(z)), dtype=np.int64)
    update_particles(
        version,
        True,
        np.tile(xhat, (M, 1)),
        np.tile(P, (M, 1, 1)),
        eps,
        log_w,
        z,
        slots,
        n_slots,
        n_live,
        np.tile(R, (len(z), 1, 1)),
        0.0,
        np.zeros(len(z)),
        np.inf,
        False,
        0.0,
        np.pi,
        1,
        np.inf,
        0.0,
        store.depth,
        *store.kernel_args(),
        poses,
        assoc,
    )

    root = poses[1:4] - poses[0]  # columns of the kernel's square root
    draws = iter(poses)
    for m in range(M):
        ref_log_w, xbar, Sx, x, new_mu, new_S = _reference_step(
            version, xhat, P, mus, Sigmas, z, slots, R, lambda mean, cov: next(draws)
        )
        assert log_w[m] == pytest.approx(ref_log_w, abs=1e-9)
        if m == 0:
            np.testing.assert_allclose(poses[0], xbar if version == 2 else xhat, atol=1e-12)
            np.testing.assert_allclose(root.T @ root, Sx if version == 2 else P, atol=1e-12)
        np.testing.assert_allclose(poses[m], (xbar if version == 2 else xhat) + eps[m] @ root, atol=1e-12)
        mu, S, state, _, _ = (a[0] for a in store.gather(5, particles=[m]))
        assert np.all(state > 0) and n_live[m] == 5 and n_slots[m] == 5
        for s in range(5):
            np.testing.assert_allclose(mu[s], new_mu[s], atol=1e-12)
            np.testing.assert_allclose([S[s, 0], S[s, 1], S[s, 1], S[s, 2]], new_S[s].ravel(), atol=1e-12)


def _reference_unknown_step(version, xhat, P, book, z, R, gate, log_p0, confirm, window, t, sample):
    """One particle's update with unknown association and tentative landmarks, literally. ``book``: slot → (μ, Σ, seen,
    born) of the live landmarks. Each row in turn: the untaken landmark of largest log N(ν; 0, S) with νᵀ S⁻¹ ν ≤ gate (S = L at
    the current proposal mean for 2.0, Q at the drawn pose for 1.0); a confirmed match weighs log N and conditions the 2.0
    proposal, a tentative one (seen < confirm) and a new landmark weigh the row's log_p0[j]. Returns log w, the proposal, the drawn pose,
    each row's slot and the book after the landmark updates and the expiry of the tentative landmarks older than the window."""
    log_w, xbar, Sx = 0.0, xhat.copy(), P.copy()
    if version == 1:
        xbar, Sx = sample(xhat, P), np.zeros((3, 3))
    taken, target = set(), []
    for j, zj in enumerate(z):
        best, best_ll = None, -np.inf
        for s, (mu, Sig, _, _) in book.items():
            if s in taken:
                continue
            zhat, Hx, Hm = _h(xbar, mu)
            S = Hx @ Sx @ Hx.T + Hm @ Sig @ Hm.T + R
            nu = _innovation(zj, zhat)
            if nu @ np.linalg.solve(S, nu) <= gate and _log_normal(nu, S) > best_ll:
                best, best_ll = s, _log_normal(nu, S)
        target.append(best)
        if best is None or book[best][2] < confirm:
            log_w += log_p0[j]
            taken.add(best)
            continue
        taken.add(best)
        log_w += best_ll
        if version == 2:
            zhat, Hx, Hm = _h(xbar, book[best][0])
            Q = Hm @ book[best][1] @ Hm.T + R
            Sx_new = np.linalg.inv(Hx.T @ np.linalg.inv(Q) @ Hx + np.linalg.inv(Sx))
            xbar = xbar + Sx_new @ Hx.T @ np.linalg.inv(Q) @ _innovation(zj, zhat)
            Sx = Sx_new
    x = sample(xbar, Sx) if version == 2 else xbar
    after, slots, n = dict(book), [], max(book) + 1
    for zj, s in zip(z, target):
        if s is None:
            a = x[2] + zj[1]
            G = np.array([[np.cos(a), -zj[0] * np.sin(a)], [np.sin(a), zj[0] * np.cos(a)]])
            after[n] = (x[:2] + zj[0] * np.array([np.cos(a), np.sin(a)]), G @ R @ G.T, 1, t)
            slots.append(n)
            n += 1
            continue
        mu, Sig, seen, born = book[s]
        zhat, _, Hm = _h(x, mu)
        K = Sig @ Hm.T @ np.linalg.inv(Hm @ Sig @ Hm.T + R)
        after[s] = (mu + K @ _innovation(zj, zhat), (np.eye(2) - K @ Hm) @ Sig, seen + 1, born)
        slots.append(s)
    for s in book:
        if after[s][2] < confirm and t - after[s][3] > window:
            del after[s]
    return log_w, x, slots, after


@pytest.mark.parametrize("version", [1, 2])
def test_unknown_association_with_tentative_landmarks_matches_a_literal_reference(version):
    """The compiled kernel with per-particle association and the tentative-landmark rule (3 sightings in 10 s) against
    the rule written out per particle: particles at different predicted poses associate differently (a row matches a
    confirmed landmark, a tentative one, or starts a landmark); weights, drawn poses, each row's slot, and every
    landmark's mean, covariance, sightings and birth after the update, with the tentative landmarks past the window gone."""
    from slamarena.estimators.fastslam.kernels import sqrt_psd

    rng = np.random.default_rng(11)
    R = np.diag([0.1**2, np.radians(2.0) ** 2])
    gate, confirm, window, t = 18.42, 3, 10.0, 20.0
    log_p0 = (
        -0.5 * gate - 0.5 * np.log(np.linalg.det(R)) - np.log(2 * np.pi) + np.array([0.0, 0.3, -0.2, 0.5])
    )  # per row (k,)
    mus = [
        np.array([4.0, 1.0]),
        np.array([2.0, 3.5]),
        np.array([3.0, -2.0]),
        np.array([-1.0, 2.0]),
        np.array([4.3, 1.4]),
    ]
    seen_born = [
        (5, 1.0),
        (1, 12.0),
        (2, 5.0),
        (1, 3.0),
        (2, 15.0),
    ]  # confirmed; tentative; tentative, old; tentative, old; tentative
    book = {}
    for s, mu in enumerate(mus):
        A = rng.normal(size=(2, 2)) * 0.05
        book[s] = (mu, A @ A.T + 0.004 * np.eye(2), *seen_born[s])
    x_true = np.array([1.0, -0.5, 0.3])
    z = np.array(
        [_h(x_true, mus[0])[0], _h(x_true, mus[1])[0], _h(x_true, mus[2])[0], _h(x_true, np.array([0.0, -3.0]))[0]]
    )
    z += rng.normal(size=z.shape) * [0.05, 0.01]
    offsets = np.array([[0.0, 0.0, 0.0], [0.05, -0.05, 0.01], [0.4, 0.3, 0.0], [-0.1, 0.1, -0.02], [0.0, 0.0, 0.2]])
    M = len(offsets)
    xhat = x_true + offsets
    B = rng.normal(size=(3, 3)) * [0.05, 0.05, 0.01]
    P = np.tile(B @ B.T + np.diag([1e-4, 1e-4, 1e-5]), (M, 1, 1))
    eps = rng.normal(size=(M, 3))

    store = LandmarkStore(M)
    for m in range(M):
        for s, (mu, Sig, seen, born) in book.items():
            store.reserve(s, 1)
            leaf, off = writable(m, s, store.depth, *store.kernel_args())
            store.leaf_mu[leaf, off] = mu
            store.leaf_S[leaf, off] = (Sig[0, 0], Sig[0, 1], Sig[1, 1])
            store.leaf_state[leaf, off] = 1
            store.leaf_seen[leaf, off] = seen
            store.leaf_born[leaf, off] = born
    store.reserve(len(book) + len(z), M * (len(z) + len(book)))
    log_w, n_slots, n_live = np.zeros(M), np.full(M, len(book), dtype=np.int64), np.full(M, len(book), dtype=np.int64)
    poses, assoc = np.empty((M, 3)), np.empty((M, len(z)), dtype=np.int64)
    update_particles(
        version,
        False,
        xhat,
        P,
        eps,
        log_w,
        z,
        np.zeros(len(z), dtype=np.int64),
        n_slots,
        n_live,
        np.tile(R, (len(z), 1, 1)),
        gate,
        log_p0,
        np.inf,
        False,
        0.0,
        np.pi,
        confirm,
        window,
        t,
        store.depth,
        *store.kernel_args(),
        poses,
        assoc,
    )

    kinds = set()
    for m in range(M):
        ref_log_w, x, slots, after = _reference_unknown_step(
            version,
            xhat[m],
            P[m],
            book,
            z,
            R,
            gate,
            log_p0,
            confirm,
            window,
            t,
            lambda mean, cov: mean + sqrt_psd(cov) @ eps[m],
        )
        assert log_w[m] == pytest.approx(ref_log_w, abs=1e-9)
        np.testing.assert_allclose(poses[m], x, atol=1e-9)
        assert assoc[m].tolist() == slots
        kinds |= {"new" if s >= len(book) else ("confirmed" if book[s][2] >= confirm else "tentative") for s in slots}
        n = int(n_slots[m])
        mu, S, state, seen, born = (a[0] for a in store.gather(n, particles=[m]))
        assert sorted(np.flatnonzero(state > 0).tolist()) == sorted(after) and n_live[m] == len(after)
        for s, (ref_mu, ref_S, ref_seen, ref_born) in after.items():
            np.testing.assert_allclose(mu[s], ref_mu, atol=1e-9)
            np.testing.assert_allclose([S[s, 0], S[s, 1], S[s, 1], S[s, 2]], ref_S.ravel(), atol=1e-12)
            assert (seen[s], born[s]) == (ref_seen, ref_born)
    assert kinds == {"new", "confirmed", "tentative"}  # every branch is exercised
    assert len({tuple(a) for a in assoc.tolist()}) > 1  # and the particles associate differently


def test_a_new_landmark_weighs_the_sensor_density_of_its_own_row():
    """The new-landmark likelihood p₀ of a row is the sensor density at the gate under THAT row's noise,
    −γ/2 − ½ log det R_j − log 2π: with range-dependent (Cartesian) noise two rows of one set at 30 m and 3 m have p₀
    differing by ½ log(det R(3 m) / det R(30 m)). Particle 0 re-observes the far landmark (exactly: ν = 0) and starts
    one for the near row; particle 1, moved away, starts both. Their log-weight difference is log N(0; 0, Q) − log p₀(30 m)."""
    slam = FastSLAM(
        version=1, particles=2, use_ids=False, range_bearing_noise="cartesian", range_bearing_cov=np.diag([0.01, 1e-4])
    )
    slam.update(np.array([[30.0, 0.0, -1.0]]))
    slam.x0[1] = [0.0, 5.0, 0.0]
    slam.update(np.array([[30.0, 0.0, -1.0], [3.0, 0.5, -1.0]]))
    sigma2 = 0.01
    Q = np.diag([sigma2, sigma2 / 30.0**2]) * 2  # Σ of the landmark (from one sighting) seen again, + R
    log_p0_far = -0.5 * slam.gate - 0.5 * np.log(sigma2**2 / 30.0**2) - np.log(2 * np.pi)
    expected = (-0.5 * np.log(np.linalg.det(Q)) - np.log(2 * np.pi)) - log_p0_far
    assert slam.log_w[0] - slam.log_w[1] == pytest.approx(expected, abs=1e-9)


# ---------------------------------------------------------------------------- Huber weight
@pytest.mark.parametrize("k", [0.5, 1.345, 3.0])
def test_huber_rho_and_scale_are_gtsams_huber(k):
    """ρ_k and 1 / w against GTSAM's Huber m-estimator (an independent implementation): loss(e) and 1 / weight(e)."""
    gtsam = pytest.importorskip("gtsam")
    from slamarena.estimators.fastslam.kernels import huber_rho, huber_scale

    huber = gtsam.noiseModel.mEstimator.Huber.Create(k)
    for e in np.linspace(0.0, 10.0, 41):
        assert huber_rho(e * e, k) == pytest.approx(huber.loss(e), rel=1e-12, abs=1e-15)
        if e > 0:
            assert huber_scale(e * e, k) == pytest.approx(1.0 / huber.weight(e), rel=1e-12)
    assert huber_rho(4.0, np.inf) == 2.0 and huber_scale(1e6, np.inf) == 1.0


def _huber_filter(version, k, known):
    f = FastSLAM(
        version=version,
        particles=20,
        seed=1,
        huber_k=k,
        use_ids=known,
        resample_threshold=1e-9,  # no resampling: the particles' weights are compared
        range_bearing_cov=[0.01, 1e-4],
        twist_cov=[0.1**2, 0.05**2],  # stated: the rows below must stay inside every particle's gate
        initial_cov=[1e-4, 1e-4, 1e-5],
    )
    ids = (7, 8) if known else (-1, -1)
    f.update([[5.0, 0.0, ids[0]], [4.0, 1.0, ids[1]]])
    f.predict([0.5, 0.05], 0.2)
    return f, ids


@pytest.mark.parametrize("known", [True, False])
@pytest.mark.parametrize("version", [1, 2])
def test_the_huber_weight_equals_the_gaussian_on_inliers(version, known):
    """Rows whose d² stays below k² in every particle: the same weights, poses and maps as the Gaussian filter."""
    z = [[4.9, -0.01, 7], [3.9, 0.98, 8]]
    runs = []
    for k in (None, 50.0):
        f, ids = _huber_filter(version, k, known)
        f.update([[r, b, i] for (r, b, _), i in zip(z, ids)])
        runs.append((f.log_w.copy(), f.x0.copy(), f.landmarks(0)[1]))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("version", [1, 2])
def test_the_huber_weight_of_an_outlier_falls_linearly_and_bounds_its_pull(version):
    """A labelled row 3 m off its landmark (d ≈ 30 σ): under the Gaussian one particle's weight differs from another's
    by ½ (d_a² − d_b²); under Huber by k (d_a − d_b) (the log det terms are the same), and the row moves the landmark
    and the drawn poses less."""
    k = 2.0
    res = {}
    for huber in (None, k):
        f, _ = _huber_filter(version, huber, True)
        xhat, P = f.predicted()
        d2 = predictive_d2(
            xhat,
            P,
            np.array([[8.0, 0.0]]),
            np.array([0]),
            f.n_slots,
            f._noise(np.array([[8.0, 0.0, 7]])),
            f.store.depth,
            f.store.roots,
            f.store.inner_child,
            f.store.leaf_mu,
            f.store.leaf_S,
        )[:, 0]
        before = f.log_w.copy()
        _, mu0, _ = f.landmarks(0)
        f.update([[8.0, 0.0, 7]])
        res[huber] = (d2, f.log_w - before, np.abs(f.landmarks(0)[1][0] - mu0[0]).max(), f.x0.copy(), xhat)
    d2, dlog, move_g, x_g, xhat = res[None]
    if version == 2:  # the weight is the proposal's normaliser at x̂: d² is the kernel's
        dd = dlog - dlog[0]
        np.testing.assert_allclose(dd, -0.5 * (d2 - d2[0]), rtol=1e-6, atol=1e-6)
        d2h, dlog_h = res[k][0], res[k][1]
        np.testing.assert_allclose(dlog_h - dlog_h[0], -k * (np.sqrt(d2h) - np.sqrt(d2h[0])), rtol=1e-6, atol=1e-6)
    assert np.min(d2) > 100
    assert res[k][2] < 0.5 * move_g
    if version == 2:  # 1.0 draws from the motion model, whatever the row
        assert np.abs(res[k][3] - xhat).max() < np.abs(x_g - xhat).max()


# ---------------------------------------------------------------------------- association at the predicted pose
@pytest.mark.parametrize("pose", ["proposal", "predicted"])
def test_association_at_the_predicted_pose_does_not_depend_on_the_conditioning_on_other_rows(pose):
    """Two mapped landmarks, a heading known to 0.014 rad, and a set whose bearings are each 0.02 rad off (inside the gate
    alone, d² ≈ 2) but in opposite directions. Conditioned on the first row (proposal), the heading moves by 0.02 and
    the second row lies at d² ≈ 180: a new landmark in every particle (the car park's duplicates). At the predicted
    pose both rows are matched."""
    f = FastSLAM(
        version=2,
        particles=10,
        seed=0,
        use_ids=False,
        association_pose=pose,
        twist_cov=[1e-4, 0.014**2],
        range_bearing_cov=[0.03**2, 0.002**2],
    )
    f.update([[4.3, -0.33, -1], [7.2, 0.87, -1]])
    f.predict([0.0, 0.0], 1.0)
    f.update([[4.3, -0.35, -1], [7.2, 0.894, -1]])
    assert np.all(f.landmark_counts() == (3 if pose == "proposal" else 2)), f.landmark_counts()


def test_association_at_the_predicted_pose_is_the_proposal_for_a_single_row():
    """One row per set: the predicted pose is the proposal, so both settings give the same run."""
    runs = []
    for pose in ("proposal", "predicted"):
        f = FastSLAM(
            version=2, particles=10, seed=3, use_ids=False, association_pose=pose, range_bearing_cov=[0.01, 1e-4]
        )
        rng = np.random.default_rng(0)
        for i in range(30):
            f.predict([0.5, 0.1], 0.5)
            f.update([[5.0 + 0.1 * rng.standard_normal(), (i % 7) * 0.4 - 1.2, -1]])
        runs.append((f.log_w.copy(), f.x0.copy(), f.landmark_counts()))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("k", [1.0, 2.0, 3.0, np.inf])
def test_the_huber_gate_holds_the_confidence_of_the_huber_density(k):
    """P(d² > γ) = 1 − confidence under the 2-D density ∝ exp(−ρ_k(d)), by numerical integration of its radial density
    d exp(−ρ_k(d)) (scipy's quad); k = ∞ is the χ²₂ gate."""
    from scipy.integrate import quad

    from slamarena.estimators.fastslam.filter import huber_gate
    from slamarena.estimators.fastslam.kernels import huber_rho
    from slamarena.estimators.models import chi2_gate

    def radial(d):
        return d * np.exp(-huber_rho(d * d, k))

    for confidence in (0.99, 0.9999):
        gate = huber_gate(confidence, k)
        kink = [] if np.isinf(k) else [k]
        total = quad(radial, 0.0, 400.0, points=kink, limit=200)[0]
        tail = quad(radial, np.sqrt(gate), 400.0, limit=200)[0]
        assert tail / total == pytest.approx(1.0 - confidence, rel=1e-6)
        if np.isinf(k):
            assert gate == pytest.approx(chi2_gate(confidence, 2), rel=1e-12)
        else:
            assert gate > chi2_gate(confidence, 2)  # heavier tails, a wider gate
