"""A log's own scan stamps beside a Sequence's scan times.

A reader may change the stamps it is given: the CARMEN reader makes each stream's stamps strictly increasing (Intel:
1612 of 13,631 scans moved, by up to 0.96 s) and keeps the originals in ``meta["scan_ipc_timestamp"]``, row for row
with ``scans.t``. Tools outside the project (evo, a relations file) know only the originals, so a trajectory written
for them carries those: :func:`log_stamps` maps scan times t (N,) to the original stamps (N,), and
:func:`sequence_times` maps original stamps back to scan times (a relations file's stamps, a trajectory file read
back).
"""

from __future__ import annotations

import numpy as np

__all__ = ["log_stamps", "sequence_times"]


def _originals(data) -> np.ndarray | None:
    """The original stamps of ``data``'s scans (K,), or None where it keeps none aligned with its scans."""
    ipc = np.asarray((getattr(data, "meta", {}) or {}).get("scan_ipc_timestamp", []), dtype=float)
    scans = getattr(data, "scans", None)
    return ipc if ipc.size and scans is not None and ipc.size == len(scans) else None


def log_stamps(data, t: np.ndarray) -> np.ndarray | None:
    """The log's original stamp of each time in ``t`` (N,), every one a scan time of ``data``; None where the reader
    changed no stamp, keeps no originals, the originals are not distinct (a log whose stamps carry no time, timed
    by scan index) or some t is not a scan time."""
    ipc = _originals(data)
    if ipc is None or np.unique(ipc).size != ipc.size:
        return None
    scan_t = data.scans.t
    k = np.clip(np.searchsorted(scan_t, t), 0, len(scan_t) - 1)
    if not np.array_equal(scan_t[k], t) or np.array_equal(ipc[k], t):
        return None
    return ipc[k]


def sequence_times(data, stamps: np.ndarray, tolerance: float) -> np.ndarray:
    """The scan time of the scan whose original stamp is nearest each of ``stamps`` (N,), NaN where none lies within
    ``tolerance``; ``stamps`` unchanged where ``data`` keeps no original stamps."""
    ipc = _originals(data)
    if ipc is None:
        return stamps
    order = np.argsort(ipc)
    k = np.clip(np.searchsorted(ipc[order], stamps), 1, ipc.size - 1)
    k = np.where(np.abs(ipc[order][k - 1] - stamps) <= np.abs(ipc[order][k] - stamps), k - 1, k)
    idx = order[k]
    return np.where(np.abs(ipc[idx] - stamps) <= tolerance, data.scans.t[idx], np.nan)
