"""User errors on the command line: one clear message and exit code 2, never a traceback; bugs keep theirs."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

CLI = [sys.executable, "-c", "from slamarena.experiments.cli import main; main()"]
GOOD = """
name: tiny
seeds: 1
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
estimators:
  - name: dead_reckoning
metrics: [ate]
figures: []
"""


def _cli(*args, cwd=None, env=None):
    return subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env, timeout=300)


def _config(tmp_path, text=GOOD):
    path = tmp_path / "exp.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def assert_user_error(result, *fragments):
    assert result.returncode == 2, (result.returncode, result.stderr[-2000:])
    assert "Traceback" not in result.stderr and "Traceback" not in result.stdout, result.stderr
    text = " ".join((result.stderr + result.stdout).split())
    for fragment in fragments:
        assert fragment in text, (fragment, text)


@pytest.mark.parametrize("jobs", ["0", "-3"])
def test_jobs_below_one_are_rejected(tmp_path, jobs):
    assert_user_error(_cli("run", _config(tmp_path), "-j", jobs, "--out", tmp_path / "o"), "--jobs must be at least 1")
    assert not (tmp_path / "o").exists()


def test_a_scheduler_that_is_not_an_address_is_rejected(tmp_path):
    assert_user_error(
        _cli("run", _config(tmp_path), "--scheduler", "not-an-address", "--out", tmp_path / "o"),
        "--scheduler must be a Dask scheduler address",
    )


def test_out_under_a_file_is_rejected(tmp_path):
    (tmp_path / "afile").write_text("x")
    assert_user_error(_cli("run", _config(tmp_path), "--out", tmp_path / "afile" / "sub"), "is a file, not a directory")


def test_a_missing_config_path_is_an_error_not_the_shipped_default(tmp_path):
    assert_user_error(_cli("run", "default.yml", "--dry-run", cwd=tmp_path), "default.yml: no such config file")
    assert _cli("run", "default", "--dry-run", cwd=tmp_path).returncode == 0  # a shipped config by its bare name


def test_figures_of_an_empty_folder_is_an_error(tmp_path):
    assert_user_error(_cli("figures", tmp_path), "no figure could be drawn")


def test_data_info_on_a_malformed_file_prints_the_file_and_line(tmp_path):
    root = tmp_path / "root" / "gtsam_examples_data"
    root.mkdir(parents=True)
    (root / "noisyToyGraph.txt").write_text("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 oops\n")
    result = _cli("--data-root", tmp_path / "root", "data", "info", "g2o:noisyToyGraph")
    assert_user_error(result, "noisyToyGraph.txt:2")


def test_unknown_dataset_name(tmp_path):
    assert_user_error(_cli("data", "info", "mrclam:7/robot1"), "unknown dataset 'mrclam:7/robot1'", "<family>:<path>")
    assert_user_error(
        _cli("data", "info", "utias:7/robot1", cwd=tmp_path),
        "dataset 'utias:7/robot1' not found",
        str(tmp_path / "7/Robot1_Odometry.dat"),
        "utias:<path>/robot<k>",
    )


def test_a_long_path_in_an_error_is_printed_in_one_piece(tmp_path):
    """Rich wraps at 80 columns without a terminal; a wrapped path cannot be copied (and broke the test above when
    pytest's temporary directory was longer)."""
    deep = tmp_path / ("a_directory_name_long_enough_to_pass_the_console_width_" * 3)
    deep.mkdir()
    result = _cli("data", "info", "utias:7/robot1", cwd=deep)
    assert str(deep / "7/Robot1_Odometry.dat") in result.stderr, result.stderr


def test_data_info_reads_a_recording_at_a_path(tmp_path):
    directory = tmp_path / "MRCLAM_Dataset7"
    directory.mkdir()
    for name, rows in {
        "Barcodes.dat": "6 63\n",
        "Landmark_Groundtruth.dat": "6 1 2 0 0\n",
        "Robot1_Odometry.dat": "1.0 0.1 0\n2.0 0 0\n",
        "Robot1_Measurement.dat": "1.5 63 2.0 0.1\n",
    }.items():
        (directory / name).write_text("# header\n" + rows)
    result = _cli("data", "info", f"utias:{directory}/robot1")
    assert result.returncode == 0 and '"landmark_observations": 1' in result.stdout, result.stderr[-2000:]


def test_run_on_a_dataset_whose_files_are_missing(tmp_path):
    import os

    text = GOOD.replace("sim:landmarks\n    params: {n_landmarks: 8, laps: 1}", "utias:6/robot1")
    env = {**os.environ, "SLAMARENA_SEARCH_SHARED": "0", "SLAMARENA_CACHE": str(tmp_path / "cache")}
    assert_user_error(
        _cli("run", _config(tmp_path, text), "--out", tmp_path / "o", env=env), "dataset 'utias:6/robot1' not found"
    )


def test_dry_run_prints_the_resolved_parameters(tmp_path):
    result = _cli("run", _config(tmp_path), "--dry-run", "--out", tmp_path / "o")
    assert result.returncode == 0, result.stderr
    text = " ".join(result.stdout.split())
    assert 'motion_model="arc"' in text and "propagate_covariance=true" in text  # defaults, filled in
    assert "n_landmarks=8" in text


def test_console_headers_keep_their_units_and_names_are_not_squeezed(tmp_path):
    result = _cli(
        "run", _config(tmp_path, GOOD.replace("metrics: [ate]", "metrics: [ate, cost]")), "--out", tmp_path / "o"
    )
    assert result.returncode == 0, result.stderr
    assert "ATE rmse [m]" in result.stderr and "step median [ms]" in result.stderr
    assert "sim_landmarks" in result.stderr and "dead_reckoning" in result.stderr  # not sim_lan… / dead_rec…


def test_map_takes_the_names_data_info_takes(tmp_path):
    """``slamarena map`` reads a log by its family and path like every other command (a bare path is short for it)."""
    from slamarena.experiments.cli_map import load_log

    log = tmp_path / "small.clf"
    log.write_text(
        "ODOM 0 0 0 0 0 0 1.0 host 0\nFLASER 4 1 2 3 4 0 0 0 0 0 0 1.1 host 0\n"
        "ODOM 1 0 0 0 0 0 1.2 host 0\nFLASER 4 1 2 3 4 1 0 0 1 0 0 1.3 host 0\n"
    )
    named, bare = load_log(f"carmen:{log}"), load_log(str(log))
    assert named.name == bare.name == f"carmen:{log}" and len(named.scans) == len(bare.scans) == 2
    with pytest.raises(Exception, match="corrected cannot be given|not found"):
        load_log(f"carmen-corrected:{tmp_path / 'missing.log'}")
