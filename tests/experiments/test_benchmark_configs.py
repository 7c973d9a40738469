"""The shipped real-data benchmarks (mrclam, victoria_park): every method, the sensor model stated once, and the two
studies that used to carry their own MRCLAM noise reading the config's."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from slamarena.experiments.config import load_config

ROOT = Path(__file__).resolve().parents[2]


def _gtsam_study():
    pytest.importorskip("gtsam")
    spec = importlib.util.spec_from_file_location("gtsam_studies", ROOT / "tests/estimators/test_gtsam_studies.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    return study


def _covariance(value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    return np.diag(a) if a.ndim == 1 else a


def test_the_mrclam_sensor_model_is_the_identified_one_and_every_method_reads_it():
    config = load_config("mrclam")
    noise = {k: _covariance(v) for k, v in _gtsam_study().mrclam_noise().items()}  # the GTSAM study reads the config's
    # odometry error over 1 s: 0.013 m, 0.05 rad; one row lasts 1/69.6 s; range 0.15 m, bearing 0.02 rad
    np.testing.assert_allclose(noise["twist_cov"], np.diag([0.013**2, 0.05**2]) * 69.6, rtol=1e-12)
    np.testing.assert_allclose(noise["range_bearing_cov"], np.diag([0.15**2, 0.02**2]), rtol=1e-12)
    assert {e.name for e in config.estimators} == {
        "dead_reckoning",
        "ekf_slam",
        "ekf_localizer",
        "gtsam_batch",
        "gtsam_isam2",
        "fastslam",
    }
    assert {e.resolved_params().get("jacobians") for e in config.estimators if e.name == "ekf_slam"} == {
        "standard",
        "fej",
        "oc",
    }
    for spec in config.estimators:
        if spec.name == "dead_reckoning":
            continue
        params = spec.resolved_params()
        np.testing.assert_array_equal(params["twist_cov"], noise["twist_cov"], err_msg=spec.label or spec.name)
        np.testing.assert_array_equal(
            params.get("range_bearing_cov", params.get("R_landmark")), noise["range_bearing_cov"]
        )
    assert [d.resolved_params() for d in config.datasets] == [
        {"path": "utias_mrclam/MRCLAM_Dataset6", "robot": k} for k in range(1, 6)
    ]


def test_the_withheld_mrclam_config_runs_mrclams_methods_unchanged_on_dataset_1():
    """mrclam_withheld takes mrclam's estimator rows (``estimators_from``), so Dataset 1 scores exactly what the shipped
    config runs."""
    shipped, withheld = load_config("mrclam"), load_config("mrclam_withheld")
    assert [(e.name, e.label, e.resolved_params()) for e in withheld.estimators] == [
        (e.name, e.label, e.resolved_params()) for e in shipped.estimators
    ]
    assert [d.resolved_params() for d in withheld.datasets] == [
        {"path": "utias_mrclam/MRCLAM_Dataset1", "robot": k} for k in range(1, 6)
    ]
    assert withheld.dataset_labels() == shipped.dataset_labels()


def test_the_gtsam_study_reads_the_configs_mrclam_noise():
    study = _gtsam_study()
    ekf = load_config("mrclam").estimators[1]
    assert ekf.name == "ekf_slam" and study.mrclam_noise() == {
        k: ekf.params[k] for k in ("twist_cov", "range_bearing_cov")
    }
    assert not hasattr(study, "MRCLAM_NOISE")


def test_victoria_park_runs_every_method_with_and_without_ids_on_one_tree_model():
    config = load_config("victoria_park")
    methods = {
        (e.name, e.resolved_params().get("use_ids"), e.resolved_params().get("association")) for e in config.estimators
    }
    assert methods == {
        ("dead_reckoning", None, None),
        ("ekf_slam", True, "nn"),
        ("ekf_slam", False, "nn"),
        ("ekf_slam", False, "jcbb"),
        ("gtsam_isam2", None, None),
        ("gtsam_batch", None, None),
        ("fastslam", True, None),
        ("fastslam", False, None),
    }
    filters = [e.resolved_params() for e in config.estimators if e.name in ("ekf_slam", "fastslam")]
    # the file's Cartesian tree model: stated (cartesian) or, in EKF-SLAM's default rows, the reader's per-observation
    # covariance, which EKF-SLAM applies when no range_bearing_cov is given
    for e in config.estimators:
        if e.name in ("ekf_slam", "fastslam"):
            p = e.resolved_params()
            assert p["range_bearing_noise"] == "cartesian" or (
                e.name == "ekf_slam" and p.get("range_bearing_cov") is None and p.get("increment_cov") is None
            ), e.label
    # two sensor models, each stated once: the file's (σ² from its noise columns) and the identified one
    models = {(str(p.get("range_bearing_cov")), str(p.get("increment_cov"))) for p in filters}
    assert len(models) == 2 and ("None", "None") in models
    identified = [e for e in config.estimators if e.resolved_params().get("increment_cov") is not None]
    assert {
        (e.name, e.resolved_params().get("use_ids"), e.resolved_params().get("association")) for e in identified
    } == {
        ("ekf_slam", True, "nn"),
        ("ekf_slam", False, "nn"),
        ("ekf_slam", False, "jcbb"),
        ("fastslam", True, None),
        ("fastslam", False, None),
        ("gtsam_isam2", None, None),
        ("gtsam_batch", None, None),
    }
    # the smoothers on the identified model take its Cartesian tree noise per observation, as the filters do
    assert {e.resolved_params()["range_bearing_noise"] for e in identified if e.name.startswith("gtsam")} == {
        "cartesian"
    }
    managed = [
        e.resolved_params() for e in config.estimators if e.name == "ekf_slam" and e.resolved_params()["window"] > 0
    ]
    keys = (
        "window",
        "window_hypotheses",
        "confirm_sightings",
        "confirm_window",
        "miss_limit",
        "sensor_range",
        "sensor_fov",
    )
    assert {p["association"] for p in managed} == {
        "nn",
        "jcbb",
    }  # NN and JCBB with one look-ahead and landmark management
    assert len({tuple(p[k] for k in keys) for p in managed}) == 1


@pytest.mark.realdata
@pytest.mark.parametrize("name,cells", [("mrclam", 40), ("mrclam_withheld", 40), ("victoria_park", 17)])
def test_the_benchmarks_plan_on_the_staged_data(name, cells, tmp_path, capsys):
    from slamarena.datasets import DatasetNotFoundError
    from slamarena.experiments.cli_run import run_from_cli

    try:
        code = run_from_cli(config=name, jobs=1, scheduler=None, out=tmp_path / "o", force=False, dry_run=True)
    except DatasetNotFoundError as exc:
        pytest.skip(f"{name}: the data is not staged ({exc})")
    text = capsys.readouterr().out
    assert code == 0 and f"{cells} cells" in text
