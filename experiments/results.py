"""The results layout of an experiment and atomic file writes.

::

    <out>/                                   e.g. results/default
      manifest.json                          config, package versions, git revision, machine, times
      .lock                                  held (flock) by the run writing here: a second run waits for it
      runs/<dataset>/<method>/<seed>/
        estimate.npz                         datasets.Estimate (save/load)
        trajectory.tum                       the estimated trajectory, TUM format (evo reads it), at the log's own
                                             stamps (write_trajectory_tum)
        groundtruth.tum                      the dataset's ground-truth trajectory, same stamps convention
                                             (where it has one): evo_ape tum groundtruth.tum trajectory.tum
        result.mcap                          with the config's ``mcap: true``: the estimate (and grid) as ROS
                                             messages for Foxglove / RViz 2
        truth.npz                            the dataset's ground truth (t, poses, landmark ids/xy)
        series.npz                           per-step metric series ("<metric>/<name>" arrays)
        metrics.json                         scalars, skipped metrics with reasons, cache keys
                                             — written last: its presence marks a finished cell
        error.json                           a failed cell's error and traceback
      summary.csv                            one row per cell
      tables/<name>.md .csv .tex
      figures/<name>.png .pdf .caption      a figure and its caption (plain text, read by the report)
      report.html report.md                  the report (slamarena report; run --report)

Every file is written to a temporary name in the same directory and renamed over the target
(``os.replace`` is atomic on POSIX), so a killed run never leaves a half-written file behind; a write that fails
(a full disk) removes its temporary.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from pathlib import Path

import numpy as np

__all__ = [
    "sha256_file",
    "atomic_write_bytes",
    "atomic_write_text",
    "write_json",
    "read_json",
    "save_npz",
    "load_npz",
    "write_trajectory_tum",
    "cell_dir",
    "MANIFEST",
    "SUMMARY",
    "LOCK",
    "CAPTION_SUFFIX",
]

MANIFEST = "manifest.json"
LOCK = ".lock"  # held (flock) by the run writing into the directory
CAPTION_SUFFIX = ".caption"  # figures/<stem>.caption beside figures/<stem>.png
SUMMARY = "summary.csv"


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:  # a full disk, a kill: no temporary is left behind
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def write_json(path: str | Path, obj) -> None:
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=True, default=_jsonable) + "\n")


def read_json(path: str | Path):
    return json.loads(Path(path).read_text())


def save_npz(path: str | Path, arrays: dict[str, np.ndarray]) -> None:
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **{k: np.asarray(v) for k, v in arrays.items()})
    atomic_write_bytes(path, buffer.getvalue())


def load_npz(path: str | Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def write_trajectory_tum(path: str | Path, t: np.ndarray, poses: np.ndarray, data=None) -> None:
    """Poses at times ``t`` as a TUM trajectory (``t x y z qx qy qz qw``, planar: z = 0, yaw quaternion).

    At the log's own stamps where ``data``'s reader changed them (:func:`slamarena.datasets.log_stamps.log_stamps`),
    so that evo and relations files find every pose: the rows then sorted by stamp (TUM readers want increasing
    stamps; the original stamps step back in places, by < 0.9 s on Intel) and a header comment says how many stamps
    the reader adjusted and that its times are the ``t`` saved beside (estimate.npz, truth.npz). Where the reader
    adjusted stamps that cannot be written so (the log's stamps repeat; ``t`` not at scans), the comment says the file
    carries the reader's times."""
    from slamarena.datasets.formats import tum
    from slamarena.datasets.log_stamps import log_stamps

    stamps = None if data is None else log_stamps(data, np.asarray(t, dtype=float))
    comment = ""
    if stamps is not None:
        order = np.argsort(stamps, kind="stable")
        comment = (
            "stamps: the log's own scan stamps. The reader adjusted "
            f"{int((stamps != t).sum())} of {len(stamps)} to make time increase; its adjusted times are 't' in "
            f"the .npz beside this file. Rows sorted by stamp: {int((np.diff(stamps) < 0).sum())} scans step back "
            "in the log's order."
        )
        t, poses = stamps[order], np.asarray(poses)[order]
    elif adjusted := (getattr(data, "meta", None) or {}).get("time_adjusted_messages"):
        comment = (
            f"stamps: the reader's times, which differ from the log's own stamps in {adjusted} messages (the log's "
            "stamps repeat, or these times are not scan times); the originals are meta['scan_ipc_timestamp']."
        )
    buffer = io.StringIO()
    tum.write(buffer, t, poses, comment)
    atomic_write_text(path, buffer.getvalue())


def cell_dir(out: Path, dataset_label: str, estimator_label: str, seed: int) -> Path:
    return Path(out) / "runs" / dataset_label / estimator_label / str(seed)


def sha256_file(path: Path) -> str:
    """SHA-256 of a file (OSError if it cannot be read): the cache keys' hash of a dataset's files, and (through
    :func:`slamarena.experiments.cell.file_digest`) of the files a cell wrote."""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()
