"""notebook/2026-11-28-ros-bags.md: CPU seconds to load the staged ACES recording as a ROS 1 bag and as its CARMEN
log, alternating, in one process.

Run from the repository root: ``python research/scripts/ros_bags_read_cpu.py``.
"""

import time

import slamarena


def main() -> None:
    for name in ["bag:aces", "carmen:aces", "bag:aces", "carmen:aces"]:
        c = time.process_time()
        slamarena.load(name)
        print(name, round(time.process_time() - c, 2), "s CPU")


if __name__ == "__main__":
    main()
