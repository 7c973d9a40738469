"""notebook/2026-11-23-ekf-slam-victoria-park.md, script 3

Run from the repository root: ``python research/scripts/ekf_slam_victoria_park_3.py``.
Moved from a heredoc of the research page, unchanged but for the wrapping
(imports at the top, the rest in ``main``) so that the test suite can import it (tests/test_research.py).
"""

from slamarena import datasets
from slamarena.experiments.noise_identification import identify


def main() -> None:
    seq = datasets.load("victoria_park")
    found = identify(
        seq,
        {"range_bearing_noise": "cartesian", "known_confidence": None},
        {"range_bearing_cov": seq.noise.range_bearing_cov, "increment_cov": seq.motion.cov[0]},
        {"range_bearing_cov": [0], "increment_cov": [0, 1, 2]},
    )
    print(found.exponents, found.score, len(found.trace))


if __name__ == "__main__":
    main()
