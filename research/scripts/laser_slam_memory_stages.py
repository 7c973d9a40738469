"""notebook/2026-11-28-rbpf-scale.md: where laser graph SLAM's peak memory lives, stage by stage.

Run from the repository root: ``python research/scripts/laser_slam_memory_stages.py [LOG [SCANS]]`` (default
``fr-clinic``, every scan). The kernel's peak resident memory (VmHWM) is reset (``/proc/self/clear_refs`` ← 5) at the
start of each stage, so each line is that stage's own peak: every 500 scans of the mapping loop (and each scan whose own peak rose more than 30 MB above the resident memory before it, with what it did), the final solve, the
scan poses and refinement, the map rendered, and the estimate assembled. Beside it the resident memory when the stage
ends and the sizes of the parts :mod:`laser_slam_memory_parts` names (tracking map, active submaps, finished submaps
dense and packed, the loop search's cache).
"""

import dataclasses
import sys
import time
from pathlib import Path

from slamarena import datasets
from slamarena.mapping.laser_slam import LaserSLAM, backend

sys.path.insert(0, str(Path(__file__).parent))
from laser_slam_memory_parts import _arrays, _hwm_mb, _mb, _pyramid_bytes, _rss_mb  # noqa: E402


def _reset_peak() -> None:
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")


def _stage(name: str, parts: str = "") -> None:
    print(f"{name}: stage peak {_hwm_mb():.0f} MB, rss at its end {_rss_mb():.0f} MB{parts}", flush=True)
    _reset_peak()


class _Stages(LaserSLAM):
    def _start(self, sequence):
        self.state = super()._start(sequence)
        return self.state

    def _scan_poses(self, run, G):
        _stage("final solve (backend.finish and GNC)")
        out = super()._scan_poses(run, G)
        _stage("scan poses and refinement")
        return out

    def _render(self, G, node_scan, scans, limit):
        grid = super()._render(G, node_scan, scans, limit)
        scratch = getattr(grid, "_scratch_cells", None)
        _stage(
            "map rendered",
            f"; map {_mb(grid.log_odds.nbytes):.0f} MB + scratch {_mb(0 if scratch is None else scratch.nbytes):.0f} MB",
        )
        return grid


def main(log: str = "fr-clinic", scans: str = "") -> None:
    seq = datasets.load(f"carmen:{log}")
    if scans:
        seq = dataclasses.replace(seq, scans=seq.scans.select(slice(0, int(scans))))
    slam = _Stages()

    last = {"rss": _rss_mb(), "nodes": 0, "submaps": 0, "tries": 0, "shape": None}

    def progress(k, K):
        run = slam.state
        now = {
            "rss": _rss_mb(),
            "nodes": len(run.L),
            "submaps": len(slam.submaps),
            "tries": len(run.loops.record.node),
            "shape": run.tracking.finest.shape if run.tracking else None,
        }
        if _hwm_mb() - last["rss"] > 30:  # a scan whose own peak rose more than 30 MB above the resident before it
            what = [
                f"{key} {last[key]} → {now[key]}"
                for key in ("nodes", "submaps", "tries", "shape")
                if now[key] != last[key]
            ]
            print(
                f"  scan {k}: peak {_hwm_mb():.0f} MB from {last['rss']:.0f} MB resident; {', '.join(what)}", flush=True
            )
        last.update(now)
        if k % 500 and k != K:
            _reset_peak()
            return
        finished = [s for s in slam.submaps if s.finished]
        dense = sum(_pyramid_bytes(s._maps) for s in finished if s._maps is not None)
        parts = (
            f"; tracking {_mb(_pyramid_bytes(run.tracking)) if run.tracking else 0:.0f} MB, active "
            f"{_mb(sum(_pyramid_bytes(s.maps) for s in run.active)):.0f} MB, finished {len(finished)}: dense "
            f"{_mb(dense):.0f} MB, packed {_mb(sum(s.packed.nbytes() for s in finished)):.0f} MB, loop cache "
            f"{_mb(sum(a.nbytes for c in run.loops._cache.values() for a in _arrays(c))):.0f} MB"
        )
        _stage(f"scans to {k}/{K}", parts)

    finish = backend.Backend.finish

    def timed_finish(self, *args, **kwargs):
        _stage("mapping loop ended, tracking map and dense submaps released")
        return finish(self, *args, **kwargs)

    backend.Backend.finish = timed_finish
    _reset_peak()
    cpu = time.process_time()
    slam.run(seq, progress=progress)
    _stage("estimate assembled (pose graph, diagnostics)")
    print(f"CPU time of the run: {time.process_time() - cpu:.1f} s (the probe's accounting included)")


if __name__ == "__main__":
    main(*sys.argv[1:])
