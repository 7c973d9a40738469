"""``slamarena bench scale``'s verdicts from measured rows (the benchmark itself is not part of the test suite)."""

from __future__ import annotations

from slamarena.experiments.benchmarks import scale


def _row(method, scans, cpu, peak, before=300.0, duration=4820.0):
    return {"log": "fr-clinic", "method": method, "scans": scans, "duration_s": duration, "cpu_s": cpu} | {
        "real_time_cpu": duration / cpu,
        "rss_before_MB": before,
        "peak_rss_MB": peak,
    }


def test_verdicts_and_projection():
    fast_small = _row("laser_slam", 6917, 120.0, 900.0)  # 40× ≥ 20×; 900 MB ≤ 1536
    slow_big = _row("rbpf", 6917, 1600.0, 2000.0)  # 3× < 5×; 2000 MB > 1536
    lines = scale.summary([fast_small, slow_big])
    assert "40.2× real time by CPU = 2.01 × 20×" in lines[0] and "(aim ≥ 20×: met)" in lines[0]
    assert "(aim ≤ 1.5 GB: met)" in lines[0]
    assert f"{300 + 600 * 17000 / 6917:.0f} MB" in lines[0]  # the added 600 MB scaled by the scans
    assert "(aim ≥ 5×: not met)" in lines[1] and "(aim ≤ 1.5 GB: not met)" in lines[1]
    short = scale.summary([_row("laser_slam", 1988, 10.0, 500.0, duration=424.0)])[0]
    assert "(aim ≤ 1.5 GB: not measurable at this size, a log of 1988 scans says little of 17000)" in short
