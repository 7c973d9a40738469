"""notebook/2026-11-28-pandas-parsing.md: the number conversion of the text readers, the hand-written decimal parser
(as of commit 0c3fc18, read from git) against today's pandas-based one, on exactly the texts the readers convert.

Run from the repository root: ``python research/scripts/pandas_parsing_ab.py``. CPU time, minimum of 5 repeats, the two
run alternately; the values are compared bit for bit.
"""

import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from slamarena.datasets import load
from slamarena.datasets.formats import _text
from slamarena.experiments.benchmarks import readers

OLD = "0c3fc18"


def old_text_module():
    source = subprocess.run(
        ["git", "show", f"{OLD}:datasets/formats/_text.py"], capture_output=True, text=True, check=True
    ).stdout
    path = Path(tempfile.mkdtemp()) / "old_text.py"
    path.write_text(source.replace("from ..errors import", "from slamarena.datasets.errors import"))
    spec = importlib.util.spec_from_file_location("old_text", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["old_text"] = module
    spec.loader.exec_module(module)
    return module


def main() -> None:
    old = old_text_module()
    for case, (names, _) in readers.cases().items():
        bodies = []
        with readers.recording(bodies):
            for name in names:
                load(name)
        best = {"hand": np.inf, "pandas": np.inf}
        for _ in range(5):
            for label, parse in (("hand", old._parse_tokens), ("pandas", _text._parse_tokens)):
                tic = time.process_time()
                for body in bodies:
                    parse(*body.args)
                best[label] = min(best[label], time.process_time() - tic)
        same = all(
            np.array_equal(old._parse_tokens(*b.args).view(np.int64), _text._parse_tokens(*b.args).view(np.int64))
            for b in bodies
        )
        print(
            f"{case}: {len(bodies)} calls, {sum(b.size for b in bodies)} numbers; hand {best['hand']:.3f} s, "
            f"pandas {best['pandas']:.3f} s, pandas/hand {best['pandas'] / best['hand']:.2f}; bit-identical {same}"
        )


if __name__ == "__main__":
    main()
