"""notebook/2026-11-28-generalisation.md (scale): what laser graph SLAM's memory holds while it maps a log.

Run from the repository root: ``python research/scripts/laser_slam_memory_parts.py [LOG [SCANS]]`` (default
``fr-clinic``, every scan). Every 500 scans: the process's resident memory, and the bytes of the tracking map, of the
active submaps' pyramids (log-odds and tracing scratch), of the finished submaps (dense where held dense; packed),
of the loop search's cached likelihood grids and of the pairwise registrations kept for the refinement.
"""

import dataclasses
import sys
import time

import numpy as np

from slamarena import datasets
from slamarena.mapping.laser_slam import LaserSLAM


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith("VmRSS")) / 1024


def _pyramid_bytes(maps) -> int:
    scratch = [getattr(g, "_scratch_cells", None) for g in maps.levels]
    return sum(g.log_odds.nbytes + (0 if s is None else s.nbytes) for g, s in zip(maps.levels, scratch))


def _hwm_mb() -> float:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith("VmHWM")) / 1024


class _Probe(LaserSLAM):
    def _start(self, sequence):
        self.state = super()._start(sequence)
        return self.state


def main(log: str = "fr-clinic", scans: str = "") -> None:
    seq = datasets.load(f"carmen:{log}")
    if scans:
        seq = dataclasses.replace(seq, scans=seq.scans.select(slice(0, int(scans))))
    slam = _Probe()

    def progress(k, K):
        if k % 500 and k != K:
            return
        run = slam.state
        finished = [s for s in slam.submaps if s.finished]
        cache = sum(a.nbytes for c in run.loops._cache.values() for a in _arrays(c))
        pairs = sum(z.nbytes + cov.nbytes for _, _, z, cov in run.pairs)
        print(
            f"scan {k}/{K}: rss {_rss_mb():.0f} MB; tracking {_mb(_pyramid_bytes(run.tracking)) if run.tracking else 0:.0f} MB; "
            f"active {_mb(sum(_pyramid_bytes(s.maps) for s in run.active)):.0f} MB; finished {len(finished)} submaps "
            f"dense {_mb(sum(_pyramid_bytes(s._maps) for s in finished if s._maps is not None)):.0f} MB, packed "
            f"{_mb(sum(s.packed.nbytes() for s in finished if s.packed is not None)):.0f} MB; loop cache {_mb(cache):.0f} MB; "
            f"pairs {len(run.pairs)} {_mb(pairs):.0f} MB; peak so far {_hwm_mb():.0f} MB",
            flush=True,
        )

    cpu = time.process_time()
    slam.run(seq, progress=progress)
    print(f"CPU time of the run: {time.process_time() - cpu:.1f} s (the probe's accounting included)")
    print(f"after the run (final solve, refinement, map rendered): peak {_hwm_mb():.0f} MB, rss {_rss_mb():.0f} MB")


def _arrays(obj):
    if isinstance(obj, np.ndarray):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _arrays(v)
    elif isinstance(obj, (list, tuple)):
        for v in obj:
            yield from _arrays(v)


def _mb(n: int) -> float:
    return n / 2**20


if __name__ == "__main__":
    main(*sys.argv[1:])
