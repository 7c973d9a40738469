"""notebook/2026-11-28-pandas-parsing.md: a SHA-256 of the pickled Sequence of every staged file-backed dataset, to
compare the readers' results across commits (run at each commit; equal digests: every array and field identical).

Run from the repository root: ``python research/scripts/reader_results_digest.py > digests.txt``.
"""

import hashlib
import pickle

from slamarena import datasets


def main() -> None:
    for info in datasets.available():
        if info.present and not info.name.startswith(("sim:", "bag:")):
            print(info.name, hashlib.sha256(pickle.dumps(datasets.load(info.name))).hexdigest())


if __name__ == "__main__":
    main()
