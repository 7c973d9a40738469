"""The README's Python examples run and print what the README says they print.

Every fenced ``python`` block of README.md is run, top to bottom, in one namespace per block. A ``print(...)`` line
followed by a comment — on the same line (``print(x)  # 3``) or on the next line alone (``# 3``) — states the
output; the text printed by the code up to and including that line must equal the comment.
"""

from __future__ import annotations

import contextlib
import io
import re
import tokenize
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks(text: str) -> list[tuple[int, str]]:
    """(first line number, source) of every fenced python block."""
    return [
        (text[: m.start(1)].count("\n") + 1, m.group(1))
        for m in re.finditer(r"^```python\n(.*?)^```", text, flags=re.MULTILINE | re.DOTALL)
    ]


def _comments(source: str) -> dict[int, str]:
    """Line number (1-based) → the text of that line's comment."""
    tokens = tokenize.generate_tokens(io.StringIO(source).readline)
    return {t.start[0]: t.string.removeprefix("#").strip() for t in tokens if t.type == tokenize.COMMENT}


def chunks(source: str) -> list[tuple[str, str | None]]:
    """The block cut after every top-level ``print`` line: (code up to there, the output it states or None)."""
    lines = source.splitlines()
    comments = _comments(source)
    out, start = [], 0
    for i, line in enumerate(lines):
        if not line.startswith("print("):
            continue
        stated = comments.get(i + 1)
        if stated is None and i + 1 < len(lines) and lines[i + 1].lstrip().startswith("#"):
            stated = comments[i + 2]
        out.append(("\n".join(lines[start : i + 1]), stated))
        start = i + 1
    out.append(("\n".join(lines[start:]), None))
    return out


def test_the_parser_finds_stated_outputs():
    source = 'x = 1\nprint(x)  # 1\ny = 2\nprint(y)\n# 2\nprint("no claim")\nz = 3\n'
    assert chunks(source) == [
        ("x = 1\nprint(x)  # 1", "1"),
        ("y = 2\nprint(y)", "2"),
        ('# 2\nprint("no claim")', None),
        ("z = 3", None),
    ]


BLOCKS = python_blocks(README.read_text())


def test_the_readme_has_python_examples():
    assert BLOCKS


@pytest.mark.parametrize("line, source", BLOCKS, ids=[f"README.md:{line}" for line, _ in BLOCKS])
def test_readme_example_prints_what_the_readme_says(line, source):
    namespace: dict = {"__name__": "__readme__"}
    for code, stated in chunks(source):
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(code, f"README.md:{line}", "exec"), namespace)
        if stated is not None:
            assert printed.getvalue().strip() == stated, f"README.md:{line}: `{code.splitlines()[-1]}`"
