"""The runner: layout, cache and resume, failures and timeouts, Dask = local, kill and resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest
from rich.console import Console

from slamarena.experiments.config import load_config
from slamarena.experiments.plan import plan
from slamarena.experiments.runner import run_experiment

TINY = """
name: tiny
seeds: 2
timeout: 120
datasets:
  - name: sim:landmarks
    params: {n_landmarks: 8, laps: 1}
estimators:
  - name: dead_reckoning
metrics: [ate, rpe, nees, map, cost]
tables:
  - name: acc
    columns: [ate.rmse, rpe.trans_rmse, nees.in_band, cost.step_median]
figures: []
"""


def _config(tmp_path, text=TINY, name="exp.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return load_config(path), path


def _quiet():
    return Console(file=open(os.devnull, "w"), width=120)


def _stamps(out):
    return {
        p.parent.name: (p.stat().st_mtime_ns, json.loads(p.read_text())["finished"])
        for p in sorted(out.glob("runs/*/*/*/metrics.json"))
    }


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("local")
    cfg, _ = _config(tmp)
    out = tmp / "out"
    code = run_experiment(cfg, out, jobs=2, console=_quiet())
    return cfg, out, code


def test_layout_and_contents(local_run):
    cfg, out, code = local_run
    assert code == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["name"] == "tiny" and manifest["finished"] and manifest["versions"]["numpy"]
    assert {"hostname", "cpus"} <= set(manifest["machine"]) and "git_revision" in manifest
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["seed"]) == [0, 1] and (summary["status"] == "ok").all()
    assert {"ate.rmse", "rpe.trans_rmse", "nees.in_band", "cost.peak_rss_mb"} <= set(summary.columns)
    assert summary["skipped"].str.contains("map: dead_reckoning estimates no landmarks").all()
    for ext in ("md", "csv", "tex"):
        assert (out / "tables" / f"acc.{ext}").exists()
    assert (out / "tables" / "monte_carlo.md").exists()
    cell = out / "runs" / "sim_landmarks" / "dead_reckoning" / "0"
    for name in ("estimate.npz", "trajectory.tum", "metrics.json", "series.npz", "truth.npz"):
        assert (cell / name).exists(), name
    assert not list(out.rglob("*.tmp*"))  # atomic writes leave no temporaries
    # the TUM file is what evo reads, and it is the estimate
    from evo.tools import file_interface

    from slamarena.datasets.estimate import Estimate

    traj = file_interface.read_tum_trajectory_file(str(cell / "trajectory.tum"))
    est = Estimate.load(cell / "estimate.npz")
    np.testing.assert_allclose(traj.timestamps, est.t)
    np.testing.assert_allclose(traj.positions_xyz[:, :2], est.poses[:, :2], atol=1e-12)
    # and the metrics are those of the estimate against the simulator's truth for that seed
    from slamarena import datasets
    from slamarena.experiments.metrics.reference import reference_of
    from slamarena.experiments.metrics.trajectory import ate

    seq = datasets.load("sim:landmarks", n_landmarks=8, laps=1, seed=0)
    expected = ate(est, reference_of(seq))[0]["rmse"]
    assert json.loads((cell / "metrics.json").read_text())["metrics"]["ate"]["rmse"] == pytest.approx(
        expected, rel=1e-12
    )
    # different seeds are different runs
    assert summary["ate.rmse"].nunique() == 2


def test_rerun_skips_finished_cells_and_keys_follow_the_spec(local_run, tmp_path):
    cfg, out, _ = local_run
    before = _stamps(out)
    assert all(c.finished() for c in plan(cfg, out))
    assert run_experiment(cfg, out, jobs=1, console=_quiet()) == 0
    assert _stamps(out) == before
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["cells"] == {"total": 2, "to_run": 0, "cached": 2}
    # a changed estimator parameter is a different cell key → recomputed
    changed, _ = _config(
        tmp_path,
        TINY.replace("  - name: dead_reckoning\n", "  - name: dead_reckoning\n    params: {motion_model: euler}\n"),
    )
    assert not any(c.finished() for c in plan(changed, out))
    assert [c.key for c in plan(cfg, out)] != [c.key for c in plan(changed, out)]


def test_changed_metric_settings_reuse_the_estimate_and_force_recomputes(tmp_path):
    text = TINY.replace("seeds: 2", "seeds: 1")
    cfg, _ = _config(tmp_path, text)
    out = tmp_path / "out"
    assert run_experiment(cfg, out, console=_quiet()) == 0
    cell = out / "runs/sim_landmarks/dead_reckoning/0"
    estimate_stamp = json.loads((cell / "estimate.json").read_text())
    estimate_mtime = (cell / "estimate.npz").stat().st_mtime_ns
    first = json.loads((cell / "metrics.json").read_text())
    # other metric settings: same estimate key, new metrics key → only the metrics are recomputed
    changed, _ = _config(
        tmp_path,
        text.replace(
            "metrics: [ate, rpe, nees, map, cost]",
            "metrics: {ate: {align: none}, rpe: {}, nees: {}, map: {}, cost: {}}",
        ),
        "changed.yaml",
    )
    [c] = plan(changed, out)
    assert c.key == first["key"] and c.metrics_key != first["metrics_key"] and not c.finished()
    assert run_experiment(changed, out, console=_quiet()) == 0
    second = json.loads((cell / "metrics.json").read_text())
    assert json.loads((cell / "estimate.json").read_text()) == estimate_stamp
    assert (cell / "estimate.npz").stat().st_mtime_ns == estimate_mtime
    assert second["metrics"]["rpe"] == first["metrics"]["rpe"]
    assert second["metrics"]["ate"]["rmse"] > first["metrics"]["ate"]["rmse"]  # no alignment: larger error
    # --force recomputes the estimate too
    assert run_experiment(changed, out, force=True, console=_quiet()) == 0
    assert (cell / "estimate.npz").stat().st_mtime_ns != estimate_mtime
    assert json.loads((cell / "metrics.json").read_text())["pid"] != second["pid"]


def test_recompute_recomputes_the_cells_of_one_method_only(tmp_path):
    """``--recompute LABEL``: the cached cells of that method are recomputed, the others kept; an unknown label is refused
    before anything runs, naming the config's labels."""
    from slamarena.experiments.cli_run import run_from_cli
    from slamarena.experiments.plan import UsageError

    text = TINY.replace("seeds: 2", "seeds: 1").replace(
        "  - name: dead_reckoning\n",
        "  - name: dead_reckoning\n  - name: dead_reckoning\n    label: euler\n    params: {motion_model: euler}\n",
    )
    cfg, path = _config(tmp_path, text)
    out = tmp_path / "out"
    assert run_experiment(cfg, out, console=_quiet()) == 0
    mtimes = lambda: {p.parts[-3]: p.stat().st_mtime_ns for p in out.glob("runs/*/*/*/estimate.npz")}
    before = mtimes()
    assert set(before) == {"dead_reckoning", "euler"}
    assert run_experiment(cfg, out, console=_quiet(), recompute=frozenset({"euler"})) == 0
    after = mtimes()
    assert after["dead_reckoning"] == before["dead_reckoning"] and after["euler"] != before["euler"]
    assert json.loads((out / "manifest.json").read_text())["cells"] == {"total": 2, "to_run": 1, "cached": 1}
    with pytest.raises(UsageError, match="no such method label.*dead_reckoning, euler"):
        run_experiment(cfg, out, console=_quiet(), recompute=frozenset({"eular"}))
    assert (
        run_from_cli(config=path, jobs=1, scheduler=None, out=out, force=False, dry_run=True, recompute=("eular",)) == 2
    )
    assert mtimes() == after


def test_failing_cell_does_not_stop_the_others_and_timeout(tmp_path):
    # a world that validates but whose route cannot be driven (it turns at its first waypoint): the cell fails when run
    broken = (
        "{world: {name: bad, walls: [], route: [[0, 0], [1, 0]], corner_radius: 1.0, description: turns at the start}}"
    )
    text = TINY.replace(
        "datasets:\n", f"datasets:\n  - name: sim:laser\n    label: broken\n    params: {broken}\n"
    ).replace("seeds: 2", "seeds: 1")
    cfg, _ = _config(tmp_path, text)
    out = tmp_path / "out"
    assert run_experiment(cfg, out, jobs=2, console=_quiet()) == 1
    summary = pd.read_csv(out / "summary.csv").set_index("dataset")
    assert summary.at["sim_landmarks", "status"] == "ok"
    assert summary.at["broken", "status"] == "error"
    assert "route" in summary.at["broken", "error"] and "Traceback" in summary.at["broken", "traceback"]
    assert "broken" in json.loads((out / "manifest.json").read_text())["failed"][0]
    # a timeout kills the cell's process and is reported like a failure
    slow = (
        TINY.replace("timeout: 120", "timeout: 0.5")
        .replace("seeds: 2", "seeds: 1")
        .replace("n_landmarks: 8, laps: 1", "n_landmarks: 50, laps: 400")
        .replace("name: dead_reckoning", "name: ekf_slam")
    )
    cfg, _ = _config(tmp_path, slow, "timeout.yaml")  # EKF-SLAM over 400 laps: far more than 0.5 s anywhere
    assert run_experiment(cfg, tmp_path / "slow", jobs=1, console=_quiet()) == 1
    summary = pd.read_csv(tmp_path / "slow" / "summary.csv")
    assert summary.at[0, "status"] == "timeout" and "timed out" in summary.at[0, "error"]


def test_dask_cluster_gives_the_local_results(local_run, tmp_path):
    distributed = pytest.importorskip("distributed")
    cfg, local_out, _ = local_run
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster:
        code = run_experiment(cfg, tmp_path / "dask", scheduler=cluster.scheduler_address, console=_quiet())
    assert code == 0
    for seed in ("0", "1"):
        a = json.loads((local_out / "runs/sim_landmarks/dead_reckoning" / seed / "metrics.json").read_text())
        b = json.loads((tmp_path / "dask/runs/sim_landmarks/dead_reckoning" / seed / "metrics.json").read_text())
        assert a["key"] == b["key"]
        for metric in ("ate", "rpe", "nees"):
            assert a["metrics"][metric] == b["metrics"][metric]
        ea = np.load(local_out / "runs/sim_landmarks/dead_reckoning" / seed / "estimate.npz")
        eb = np.load(tmp_path / "dask/runs/sim_landmarks/dead_reckoning" / seed / "estimate.npz")
        np.testing.assert_array_equal(ea["poses"], eb["poses"])


def test_killed_run_resumes_without_redoing_finished_cells(tmp_path):
    _, path = _config(tmp_path, TINY.replace("seeds: 2", "seeds: 3"))
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-c",
        "from slamarena.experiments.cli import main; main()",
        "run",
        str(path),
        "--out",
        str(out),
        "--jobs",
        "1",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(_stamps(out)) < 1:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the runner and its cell process, mid-way
    proc.wait()
    finished = _stamps(out)
    assert 1 <= len(finished) < 3, "the kill must land after the first cell and before the last"
    assert not (out / "summary.csv").exists()
    cfg = load_config(path)
    assert run_experiment(cfg, out, jobs=2, console=_quiet()) == 0
    after = _stamps(out)
    assert len(after) == 3
    for seed, stamp in finished.items():
        assert after[seed] == stamp  # not recomputed
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["cells"]["cached"] == len(finished)


def test_methods_restricted_to_datasets(tmp_path):
    text = TINY.replace("datasets:\n", "datasets:\n  - name: sim:localization\n    params: {duration: 5.0}\n").replace(
        "  - name: dead_reckoning\n",
        "  - name: dead_reckoning\n  - name: dead_reckoning\n    label: dr_euler\n    params: {motion_model: euler}\n"
        "    datasets: [sim_landmarks]\n",
    )
    cfg, _ = _config(tmp_path, text)
    grid = {c.id for c in plan(cfg, tmp_path / "o")}
    assert grid == {
        f"{d}/{m}/{s}" for d in ("sim_localization", "sim_landmarks") for m in ("dead_reckoning",) for s in (0, 1)
    } | {f"sim_landmarks/dr_euler/{s}" for s in (0, 1)}


def test_dry_run_lists_the_grid(tmp_path, capsys):
    from slamarena.experiments.cli_run import run_from_cli

    _, path = _config(tmp_path)
    assert run_from_cli(config=path, jobs=1, scheduler=None, out=tmp_path / "o", force=False, dry_run=True) == 0
    text = capsys.readouterr().out
    assert "2 cells" in text and "to run" in text
    assert not (tmp_path / "o" / "runs").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\n")
    assert run_from_cli(config=bad, jobs=1, scheduler=None, out=None, force=False, dry_run=False) == 2


def test_a_recording_at_a_path_runs_and_its_files_are_in_the_cache_key(tmp_path):
    """``utias:<dir>/robot<k>`` in a config: the cell reads that directory, and changing a file there recomputes it."""
    directory = tmp_path / "MRCLAM_Dataset7"
    directory.mkdir()
    files = {
        "Barcodes.dat": "6 63\n7 81\n",
        "Landmark_Groundtruth.dat": "6 1 2 0 0\n7 3 4 0 0\n",
        "Robot2_Odometry.dat": "".join(f"{10 + 0.1 * k:.1f} 0.2 0.05\n" for k in range(40)),
        "Robot2_Measurement.dat": "10.5 63 1.5 0.1\n11.5 81 2.5 -0.2\n",
        "Robot2_Groundtruth.dat": "".join(f"{10 + 0.1 * k:.1f} {0.02 * k:.3f} 0 0\n" for k in range(40)),
    }
    for name, rows in files.items():
        (directory / name).write_text("# header\n" + rows)
    text = TINY.replace(
        "  - name: sim:landmarks\n    params: {n_landmarks: 8, laps: 1}\n",
        f"  - name: utias:{directory}/robot2\n    label: mrclam7\n",
    )
    cfg, _ = _config(
        tmp_path,
        text.replace("[ate, rpe, nees, map, cost]", "[ate, cost]").replace(
            "[ate.rmse, rpe.trans_rmse, nees.in_band, cost.step_median]", "[ate.rmse, cost.step_median]"
        ),
    )
    out = tmp_path / "out"
    assert run_experiment(cfg, out, jobs=1, console=_quiet()) == 0
    [cell] = plan(cfg, out)
    assert cell.finished() and json.loads((cell.dir / "metrics.json").read_text())["metrics"]["ate"]["matched"] == 40
    (directory / "Robot2_Measurement.dat").write_text("# header\n10.5 63 1.5 0.1\n")
    [changed] = plan(cfg, out)
    assert changed.key != cell.key and not changed.finished()


def test_single_threaded_config_limits_the_threads_of_every_cell(tmp_path):
    """single_threaded: true gives each cell process one BLAS/OpenMP/numba thread; the default leaves the environment alone."""
    from slamarena.experiments.plan import cell_env

    plain, _ = _config(tmp_path)
    single, _ = _config(tmp_path, TINY.replace("timeout: 120", "timeout: 120\nsingle_threaded: true"), "single.yaml")
    assert "OPENBLAS_NUM_THREADS" not in cell_env(plain)
    env = cell_env(single)
    assert {env[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")} == {
        "1"
    }
    assert env["SLAMARENA_DATA"] == cell_env(plain)["SLAMARENA_DATA"]


def test_table_numbers_three_significant_digits_and_counts_in_full():
    from slamarena.experiments.tables import format_number

    assert [format_number(x) for x in (2724.0, 50000.0, 0.0, 0.05432, 2724.5, 3.2e-5, float("nan"))] == [
        "2724",
        "50000",
        "0",
        "0.0543",
        "2.72e+03",
        "3.20e-05",
        "–",
    ]
