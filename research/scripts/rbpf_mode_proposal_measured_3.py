"""notebook/2026-11-23-rbpf-mode-proposal-measured.md, an inline command

Run from the repository root: ``python research/scripts/rbpf_mode_proposal_measured_3.py``.
Moved from a one-line ``python -c`` of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

import dataclasses
import time

from slamarena import datasets
from slamarena.mapping.rbpf import RBPF


def main() -> None:
    s = datasets.load("carmen:intel")
    s = dataclasses.replace(s, scans=s.scans.select(slice(0, 2000)))
    RBPF(particles=30).run(dataclasses.replace(s, scans=s.scans.select(slice(0, 20))))
    span = s.scans.t[-1] - s.scans.t[0]
    for proposal in ("gaussian", "mode", "gaussian", "mode"):
        t0 = time.process_time()
        e = RBPF(particles=30, proposal=proposal).run(s)
        cpu = time.process_time() - t0
        print(
            proposal,
            "CPU",
            round(cpu, 1),
            "s for",
            round(span),
            "s of log: x real time",
            round(span / cpu, 2),
            "Gauss-Newton iterations",
            int(e.diagnostics["iterations"].sum()),
            "filter steps",
            e.meta["filter_steps"],
            flush=True,
        )


if __name__ == "__main__":
    main()
