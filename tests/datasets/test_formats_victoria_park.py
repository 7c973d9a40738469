"""Victoria Park reader: both variants, Sequence and PoseGraph views, the GTSAM wheel's copy."""

from __future__ import annotations

import numpy as np
import pytest
from checks import load_staged, staged

from slamarena.datasets import DataFormatError, Increments, load
from slamarena.datasets.formats import victoria_park as vp

pytestmark = pytest.mark.realdata


@pytest.fixture(scope="module", params=["isam", "gtsam"])
def variant_and_sequence(request):
    name = {"isam": "victoria_park/victoriaPark_isam.txt", "gtsam": "victoria_park/victoria_park_gtsam.txt"}[
        request.param
    ]
    return request.param, vp.read(staged(name), request.param)


def test_counts_first_records_and_time_is_pose_index(variant_and_sequence):
    _, s = variant_and_sequence
    assert isinstance(s.motion, Increments)
    assert len(s.motion) == 6968 and s.meta["poses"] == 6969
    assert len(s.range_bearing) == 3640 and np.unique(s.range_bearing.landmark_id).size == 151
    assert np.allclose(s.motion.delta[0], [0.000985144, -3.63222e-10, -1.54136e-06])
    assert s.motion.t[0] == 1.0 and s.motion.t[-1] == 6968.0
    # first LANDMARK 4 5 11.5387 -3.2007: pose id 4 is the 5th pose (index 4)
    rb = s.range_bearing
    assert rb.t[0] == 4.0 and rb.landmark_id[0] == 5
    assert np.isclose(rb.range[0], np.hypot(11.5387, -3.2007)) and np.isclose(
        rb.bearing[0], np.arctan2(-3.2007, 11.5387)
    )
    assert 4.5 < rb.range.min() and rb.range.max() < 21.0  # SOURCE.md: 4.6-20.7 m
    assert "no timestamps" in s.meta["time"]


def test_both_noise_conventions_give_the_same_noise(variant_and_sequence):
    variant, s = variant_and_sequence
    assert np.allclose(s.noise.increment_cov, np.diag([1e-4, 4e-6, 4e-6]), rtol=1e-5)
    assert np.allclose(s.motion.cov[123], np.diag([1e-4, 4e-6, 4e-6]), rtol=1e-5)
    # Cartesian sigma^2 = 0.4 per axis -> range variance 0.4, bearing variance 0.4 / r^2 exactly
    per_obs = s.meta["range_bearing_cov_per_observation"]
    r = s.range_bearing.range
    assert np.allclose(per_obs[:, 0, 0], 0.4, rtol=1e-5) and np.allclose(per_obs[:, 1, 1], 0.4 / r**2, rtol=1e-5)
    assert np.allclose(per_obs[:, 0, 1], 0.0, atol=1e-12)
    assert np.isclose(s.noise.range_bearing_cov[0, 0], 0.4, rtol=1e-5)


def test_polar_covariance_matches_monte_carlo(rng):
    """J Σ Jᵀ for the Cartesian → polar map, checked by sampling (the derivation in the docstring)."""
    p = np.array([11.5387, -3.2007])
    samples = p + rng.normal(scale=np.sqrt(0.4), size=(200_000, 2))
    polar = np.column_stack([np.hypot(*samples.T), np.arctan2(samples[:, 1], samples[:, 0])])
    r = np.hypot(*p)
    C = np.cov(polar.T)
    assert np.allclose(np.diag(C), [0.4, 0.4 / r**2], rtol=0.02)
    assert abs(C[0, 1]) < 4 * np.sqrt(C[0, 0] * C[1, 1] / len(samples))  # zero within 4 standard errors


def test_pose_graph_view():
    g = vp.read_graph(staged("victoria_park/victoriaPark_isam.txt"), "isam")
    assert g.n_nodes == 6969 and g.n_edges == 6968 and g.odometry_mask().all()
    assert g.landmark_kind == "xy" and g.landmark_z.shape == (3640, 2)
    assert np.allclose(g.edge_information[0], np.diag([1e4, 2.5e5, 2.5e5]))
    assert np.allclose(g.landmark_information[0], np.eye(2) * 1.581139**2)
    assert not np.isin(g.landmark_id, g.node_ids).any()


def test_registry_default_is_gtsam_and_falls_back_to_the_gtsam_wheel(monkeypatch):
    pytest.importorskip("gtsam")
    from slamarena.datasets import DatasetNotFoundError, dataroot
    from slamarena.datasets.registry import resolve

    s = load("victoria_park")
    assert s.meta["variant"] == "gtsam"
    monkeypatch.setattr(dataroot, "data_roots", lambda existing_only=True: [])
    assert resolve("victoria_park").present()
    s2 = load("victoria_park")
    assert "gtsam" in s2.meta["file"] and np.array_equal(s2.motion.delta, s.motion.delta)
    with pytest.raises(DatasetNotFoundError, match="victoriaPark_isam.txt"):
        load("victoria_park:isam")


def test_the_variant_belongs_to_the_file():
    """Each catalogued name is one file with its noise convention; a variant given to it would read the other copy's
    numbers with the wrong convention (a covariance as a square-root information), so it is an error."""
    from slamarena.datasets import DatasetNameError

    with pytest.raises(DatasetNameError, match="variant cannot be given.*victoria_park:isam"):
        load("victoria_park", variant="isam")
    isam = load_staged("victoria_park:isam")
    assert isam.meta["variant"] == "isam" and isam.meta["file"].endswith("victoriaPark_isam.txt")
    at_path = load(f"victoria_park:{isam.meta['file']}", variant="isam")
    np.testing.assert_array_equal(at_path.motion.cov, isam.motion.cov)


def test_broken_odometry_chain_is_reported(tmp_path):
    f = tmp_path / "vp.txt"
    f.write_text("ODOMETRY 0 1 1 0 0 100 0 0 500 0 500\nLANDMARK 1 2 3 4 1 0 1\nODOMETRY 3 4 1 0 0 100 0 0 500 0 500\n")
    with pytest.raises(DataFormatError) as err:
        vp.read(f)
    assert err.value.line == 3 and "previous pose 1" in str(err.value)


@pytest.mark.parametrize(
    "variant, noise, fragment",
    [("isam", "1 0 0", "positive-definite landmark"), ("gtsam", "0.4 1 0.4", "positive-definite landmark")],
)
def test_singular_noise_is_reported(tmp_path, variant, noise, fragment):
    f = tmp_path / "vp.txt"
    f.write_text(f"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 2 3 4 {noise}\n")
    with pytest.raises(DataFormatError) as err:
        vp.read(f, variant)
    assert err.value.line == 2 and fragment in str(err.value)


def test_noise_singular_only_to_rounding_is_reported(tmp_path):
    """R = [[1, 1, 1e3], [0, 0, 0], [0, 0, 1]] gives a rank-2 RᵀR whose smallest eigenvalue rounds to a tiny positive
    number: the fuzz test's case, which reached numpy's inverse and raised LinAlgError."""
    f = tmp_path / "vp.txt"
    f.write_text("ODOMETRY 0 1 0 0 0 1 1 1e3 0 0 1\n")
    with pytest.raises(DataFormatError) as err:
        vp.read(f, "isam")
    assert err.value.line == 1 and "positive-definite pose-constraint" in str(err.value)


def test_catalogue_reader_options_as_a_params_model_or_keywords():
    path = str(staged("victoria_park/victoriaPark_isam.txt"))
    given = vp.load({"file": path}, "vp", params=vp.VictoriaParkSource(path=path, variant="isam", as_graph=True))
    keywords = vp.load({"file": path}, "vp", path=path, variant="isam", as_graph=True)
    assert vp.load.Params is vp.VictoriaParkSource
    assert given.meta["variant"] == keywords.meta["variant"] == "isam" and given.n_edges == keywords.n_edges == 6968
    np.testing.assert_array_equal(given.edge_information, keywords.edge_information)
