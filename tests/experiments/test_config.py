"""Experiment configs: every mistake rejected before anything runs, with the field path."""

from __future__ import annotations

import textwrap

import pytest

from slamarena.experiments.config import FIGURES, ConfigError, load_config, sanitize


def _write(tmp_path, text):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    return path


GOOD = """
name: tiny
seeds: [0, 3]
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 10}
estimators:
  - name: dead_reckoning
    params: {motion_model: euler}
metrics: [ate, cost]
tables:
  - name: acc
    columns: [ate.rmse, cost.wall]
figures: [errors]
"""


def test_good_config_and_derived_values(tmp_path):
    cfg = load_config(_write(tmp_path, GOOD))
    assert cfg.seed_list() == [0, 3]
    assert cfg.dataset_labels() == ["sim_landmarks"] and cfg.estimator_labels() == ["dead_reckoning"]
    assert set(cfg.enabled_metrics()) == {"ate", "cost"}
    assert cfg.enabled_metrics()["ate"].align == "se2"
    assert str(cfg.output_dir()) == "results/tiny"


@pytest.mark.parametrize(
    "change,path,message",
    [
        (("name: tiny", "name: tiny\nbogus: 1"), "bogus", "Extra inputs"),
        (
            (
                "sim:landmarks\n    params: {n_landmarks: 10}",
                "utias:6/robot1\n    params: {path: /data/MRCLAM_Dataset7}",
            ),
            "datasets.0",
            "path cannot be given",
        ),
        (
            (
                "sim:landmarks\n    params: {n_landmarks: 10}",
                "utias\n    params: {path: /data/MRCLAM_Dataset7, robt: 1}",
            ),
            "datasets.0",
            "params.robot: Field required; params.robt: not a parameter of MrclamSource; did you mean params.robot?",
        ),
        (
            ("sim:landmarks\n    params: {n_landmarks: 10}", "victoria_park\n    params: {varient: isam}"),
            "datasets.0",
            "params.varient: not a parameter of VictoriaParkSource; did you mean params.variant?",
        ),
        (
            ("sim:landmarks\n    params: {n_landmarks: 10}", "mrclam:/data/MRCLAM_Dataset7/robot1"),
            "datasets.0",
            "unknown dataset 'mrclam:/data/MRCLAM_Dataset7/robot1'",
        ),
        (("seeds: [0, 3]", "seeds: 0"), "seeds", "≥ 1"),
        (("seeds: [0, 3]", "seeds: [1, 1]"), "seeds", "distinct"),
        (("sim:landmarks", "sim:nowhere"), "datasets.0", "unknown dataset 'sim:nowhere'"),
        (("{n_landmarks: 10}", "{n_landmarks: ten}"), "datasets.0", "n_landmarks"),
        (
            ("{n_landmarks: 10}", "{n_landmark: 10}"),
            "datasets.0",
            "params.n_landmark: not a parameter of LandmarkWorldParams; did you mean params.n_landmarks?",
        ),
        (
            ("{n_landmarks: 10}", "{n_landmarks: -5}"),
            "datasets.0",
            "params.n_landmarks: Input should be greater than or equal to 1",
        ),
        (("{n_landmarks: 10}", "{seed: 4}"), "datasets.0", "set by the runner"),
        (("name: dead_reckoning", "name: kalman"), "estimators.0", "unknown method 'kalman'"),
        (
            ("{motion_model: euler}", "{motion_model: rk4}"),
            "estimators.0",
            "params.motion_model: Input should be 'arc' or 'euler'",
        ),
        (
            ("{motion_model: euler}", "{speed: 3}"),
            "estimators.0",
            "params.speed: not a parameter of DeadReckoningParams; its parameters: motion_model",
        ),
        (
            (
                "name: dead_reckoning\n    params: {motion_model: euler}",
                "name: laser_slam\n    params: {loop: {levl: 2}}",
            ),
            "estimators.0",
            "params.loop.levl: not a parameter of LoopClosureParams; did you mean params.loop.level?",
        ),
        (
            (
                "name: dead_reckoning\n    params: {motion_model: euler}",
                "name: laser_slam\n    params: {loop_level: 2}",
            ),
            "estimators.0",
            "params.loop_level: not a parameter of LaserSLAMParams; did you mean params.loop.level?",
        ),
        (
            ("metrics: [ate, cost]", "metrics: {ate: {algin: se2}, cost: {}}"),
            "metrics.ate.algin",
            "algin: not a parameter of ATEParams; did you mean align?",
        ),
        (
            ("{motion_model: euler}", "{initial_sigma: [0.1, -1, 0]}"),
            "estimators.0",
            "params.initial_sigma.1: Input should be greater than or equal to 0",
        ),
        (
            ("metrics: [ate, cost]", "metrics: {ate: {align: se3}, cost: {}}"),
            "metrics.ate.align",
            "'none', 'se2' or 'sim2'",
        ),
        (("metrics: [ate, cost]", "metrics: {ate: {}, cost: {}, speed: {}}"), "metrics.speed", "Extra inputs"),
        (("[ate.rmse, cost.wall]", "[ate.rmse, ate.nope]"), "tables.0.columns", "unknown column 'ate.nope'"),
        (("[ate.rmse, cost.wall]", "[ate.rmse, rpe.trans_rmse]"), "", "not enabled under metrics: rpe"),
        (("figures: [errors]", "figures: [heatmap]"), "figures.0", "Input should be"),
        (
            ("{motion_model: euler}", "{motion_model: euler}\n    datasets: [utias_6_robot1]"),
            "",
            "estimators.0.datasets names unknown dataset labels",
        ),
        (
            ("metrics: [ate, cost]", "metrics: {ate: {}, cost: {}, relations: {file: /no/such.relations}}"),
            "metrics.relations.file",
            "does not exist",
        ),
        (("name: tiny", "name: my experiment"), "name", "plain directory name"),
        (  # silently dropped the method
            ("{motion_model: euler}", "{motion_model: euler}\n    datasets: []"),
            "estimators.0.datasets",
            "an empty list runs the method on no dataset",
        ),
        (  # passed, then an empty MemoryError in the cell
            ("{n_landmarks: 10}", "{n_landmarks: 1000000000000}"),
            "datasets.0",
            "n_landmarks = 1000000000000",
        ),
    ],
)
def test_mistakes_are_rejected_with_their_path(tmp_path, change, path, message):
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, GOOD.replace(*change)))
    text = str(err.value)
    assert message in text
    assert f"  {path}" in text if path else True


def test_a_recording_at_a_path_by_name_or_by_params(tmp_path):
    """Any recording of a known format, without editing code: the family and its path, in either form."""
    text = GOOD.replace(
        "  - name: sim:landmarks\n    params: {n_landmarks: 10}\n",
        """\
  - name: utias:/data/MRCLAM_Dataset7/robot1
  - name: utias
    params: {path: /data/MRCLAM_Dataset7, robot: 2}
    label: mrclam7_robot2
  - name: carmen:/data/new.clf
    params: {max_range: 50.0}
""",
    )
    cfg = load_config(_write(tmp_path, text))
    assert cfg.dataset_labels() == ["utias_data_MRCLAM_Dataset7_robot1", "mrclam7_robot2", "carmen_data_new.clf"]
    assert cfg.datasets[0].resolved_params() == {"path": "/data/MRCLAM_Dataset7", "robot": 1}
    assert cfg.datasets[1].resolved_params() == {"path": "/data/MRCLAM_Dataset7", "robot": 2}
    assert (
        cfg.datasets[2].resolved_params()["max_range"] == 50.0
        and cfg.datasets[2].resolved_params()["path"] == "/data/new.clf"
    )


def test_duplicate_labels_need_a_label(tmp_path):
    text = GOOD.replace(
        "    params: {n_landmarks: 10}\n",
        "    params: {n_landmarks: 10}\n  - name: sim:landmarks\n    params: {n_landmarks: 20}\n",
    )
    with pytest.raises(ConfigError, match="labels must be unique"):
        load_config(_write(tmp_path, text))
    text = text.replace("params: {n_landmarks: 20}", "params: {n_landmarks: 20}\n    label: lm20")
    assert load_config(_write(tmp_path, text)).dataset_labels() == ["sim_landmarks", "lm20"]


def test_shipped_default_config_is_valid():
    cfg = load_config(None)
    assert cfg.name == "default"
    assert all(d.is_simulator for d in cfg.datasets)  # needs no downloaded data
    assert "dead_reckoning" in cfg.estimator_labels()


def test_not_a_mapping_and_bad_yaml(tmp_path):
    with pytest.raises(ConfigError, match="mapping"):
        load_config(_write(tmp_path, "- a\n- b\n"))
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(_write(tmp_path, "name: [unclosed\n"))
    with pytest.raises(ConfigError, match="no such config"):
        load_config(tmp_path / "missing.yaml")


def test_figure_kinds_match_paper_figures():
    from slamarena.paper_figures.make import FIGURES as IMPLEMENTED

    assert set(FIGURES) == set(IMPLEMENTED)


def test_sanitize():
    assert sanitize("utias:6/robot1") == "utias_6_robot1"
    assert sanitize("sim:landmarks") == "sim_landmarks"
    assert sanitize("carmen-corrected:intel") == "carmen-corrected_intel"


def test_every_shipped_config_is_valid():
    from importlib.resources import files

    shipped = [p for p in files("experiments").joinpath("configs").iterdir() if p.name.endswith(".yaml")]
    assert {"default.yaml", "scaling.yaml"} <= {p.name for p in shipped}
    for p in shipped:
        assert load_config(p.name.removesuffix(".yaml")).name == p.name.removesuffix(".yaml")


def test_published_rows_are_checked_and_printed_beside_ours_never_best(tmp_path):
    import pandas as pd

    from slamarena.experiments.tables import aggregate, to_markdown, with_published

    text = (
        GOOD
        + """published:
  - label: graph mapping (Kümmerle 2009)
    citation: Kümmerle et al., Auton. Robots 27(4), 2009, Table 2
    values: {sim_landmarks: {ate.rmse: 0.001}}
"""
    )
    cfg = load_config(_write(tmp_path, text))
    frame = pd.DataFrame(
        [
            {"dataset": "sim_landmarks", "estimator": e, "seed": s, "status": "ok", "ate.rmse": v, "cost.wall": 1.0}
            for e, vals in (("a", (0.2, 0.3)), ("b", (0.5, 0.4)))
            for s, v in enumerate(vals)
        ]
    )
    means, stds, best = with_published(*aggregate(frame, ["ate.rmse", "cost.wall"]), cfg.published)
    md = to_markdown(means, stds, best, cfg.published)
    assert "| sim_landmarks | graph mapping (Kümmerle 2009) (published) | – | 0.001 | – |" in md
    assert "| sim_landmarks | a | 2 | **0.25 ± 0.0707** |" in md  # ours is best although the quoted row is lower
    assert "Kümmerle et al., Auton. Robots 27(4), 2009, Table 2" in md
    for bad, message in (
        (("sim_landmarks: {ate.rmse", "utias_6_robot9: {ate.rmse"), "names unknown dataset labels"),
        (("{ate.rmse: 0.001}", "{ate.nope: 0.001}"), "unknown column 'ate.nope'"),
    ):
        with pytest.raises(ConfigError, match=message):
            load_config(_write(tmp_path, text.replace(*bad)))


def test_a_method_is_refused_on_a_dataset_without_the_streams_it_needs(tmp_path):
    text = GOOD.replace(
        "  - name: sim:landmarks\n",
        "  - name: sim:localization\n    params: {duration: 5.0}\n  - name: sim:landmarks\n",
    )
    with pytest.raises(
        ConfigError,
        match="estimators.0 \\(ekf_slam\\) cannot run on dataset 'sim_localization': it needs range_bearing",
    ):
        load_config(
            _write(tmp_path, text.replace("name: dead_reckoning\n    params: {motion_model: euler}", "name: ekf_slam"))
        )
    with pytest.raises(ConfigError, match="needs scans"):
        load_config(
            _write(tmp_path, GOOD.replace("name: dead_reckoning\n    params: {motion_model: euler}", "name: grid_slam"))
        )
    restricted = text.replace(
        "name: dead_reckoning\n    params: {motion_model: euler}", "name: ekf_slam\n    datasets: [sim_landmarks]"
    )
    assert load_config(_write(tmp_path, restricted)).estimators[0].name == "ekf_slam"


def test_a_config_reduced_to_part_of_its_grid_keeps_its_settings():
    from slamarena.experiments.config import load_config

    full = load_config("consistency")
    part = full.reduced(datasets=["hard"], estimators=["ekf_slam", "ekf_slam_initP"], seeds=3)
    assert part.dataset_labels() == ["hard"] and part.seed_list() == [0, 1, 2]
    assert part.estimator_labels() == ["ekf_slam"]  # initP runs on the default world only: dropped with it
    assert part.datasets[0].resolved_params() == full.datasets[1].resolved_params() and part.metrics == full.metrics
    laser = load_config("kummerle2009").reduced(datasets=["intel"])
    assert all(set(row.values) == {"intel"} for row in laser.published)


def test_a_world_too_large_for_the_machine_names_its_size_and_the_memory(tmp_path):
    with pytest.raises(ConfigError, match=r"≈ [0-9.e+]+ GiB, beyond the [0-9.]+ GiB of memory available"):
        load_config(_write(tmp_path, GOOD.replace("{n_landmarks: 10}", "{n_landmarks: 1000000000000}")))


def test_a_duplicate_key_names_its_path_and_both_lines(tmp_path):
    """YAML keeps the last of two equal keys silently; a config refuses it (here seeds, and a method's parameter)."""
    with pytest.raises(ConfigError, match=r"exp.yaml:4: seeds: a key given twice \(first on line 3\)"):
        load_config(_write(tmp_path, GOOD.replace("seeds: [0, 3]", "seeds: [0, 3]\nseeds: 5")))
    twice = "{motion_model: euler, motion_model: arc}"
    with pytest.raises(ConfigError, match=r"estimators.0.params.motion_model: a key given twice"):
        load_config(_write(tmp_path, GOOD.replace("{motion_model: euler}", twice)))


def test_a_config_that_is_not_utf8_is_one_line_naming_file_and_line(tmp_path):
    path = tmp_path / "exp.yaml"
    path.write_bytes(textwrap.dedent(GOOD).replace("name: tiny", "name: tiny\ndescription: caf\xe9").encode("latin-1"))
    with pytest.raises(ConfigError, match=r"exp.yaml:3: not UTF-8 text \(byte 0xe9"):
        load_config(path)
    path.write_bytes(b"\xef\xbb\xbf" + textwrap.dedent(GOOD).encode())  # a byte order mark is fine
    assert load_config(path).name == "tiny"


def test_estimators_from_takes_a_shipped_configs_rows_unchanged(tmp_path):
    """The same methods on other data: ``estimators_from: NAME`` in place of ``estimators``."""
    shipped = load_config("mrclam").estimators
    text = GOOD.replace(
        "estimators:\n  - name: dead_reckoning\n    params: {motion_model: euler}", "estimators_from: mrclam"
    )
    path = _write(tmp_path, text.replace("tables:\n  - name: acc\n    columns: [ate.rmse, cost.wall]\n", ""))
    assert [(e.name, e.label, e.resolved_params()) for e in load_config(path).estimators] == [
        (e.name, e.label, e.resolved_params()) for e in shipped
    ]
    with pytest.raises(ConfigError, match="exp.yaml: estimators_from: give the estimator rows or estimators_from"):
        load_config(_write(tmp_path, GOOD + "estimators_from: mrclam\n"))
    with pytest.raises(ConfigError, match="estimators_from: the name of a shipped config"):
        load_config(_write(tmp_path, text.replace("estimators_from: mrclam", "estimators_from: dir/mrclam.yaml")))
    with pytest.raises(ConfigError, match="estimators_from: nosuch: no such config file"):
        load_config(_write(tmp_path, text.replace("estimators_from: mrclam", "estimators_from: nosuch")))
    with pytest.raises(ConfigError, match="estimators_from: mrclam leads back to itself"):
        load_config("mrclam_withheld", _via=("mrclam",))
