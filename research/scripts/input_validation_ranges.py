"""notebook/2026-11-28-input-validation.md: rows the readers' physical ranges drop from the staged recordings.

Run from the repository root: ``python research/scripts/input_validation_ranges.py``. Loads every catalogued
recording of MRCLAM (``utias``), Plaza and CARMEN (raw and corrected) and prints its
``meta["dropped_lines"]["out_of_range"]`` (per stream, the number of dropped lines). Reads the staged data; no sizes.
"""

import warnings

from slamarena.datasets import load
from slamarena.datasets.catalogue import CATALOGUE


def main() -> None:
    warnings.simplefilter("ignore")
    for n in [n for n in CATALOGUE if n.split(":")[0] in ("utias", "plaza", "carmen", "carmen-corrected")]:
        d = load(n).meta.get("dropped_lines", {}).get("out_of_range")
        print(n, d if not isinstance(d, dict) else {k: len(v) for k, v in d.items()}, flush=True)


if __name__ == "__main__":
    main()
