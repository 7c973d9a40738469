"""Vectorised parsing of whitespace-separated text records, with exact error locations.

Every text reader of :mod:`slamarena.datasets.formats` works the same way:

1. :func:`read_lines` reads the whole (optionally ``.gz``/``.bz2``-compressed) file and splits it
   into lines once (:func:`numeric_table` skips even that and works on the raw bytes);
2. :func:`tags` takes the first token of every line (one cheap string operation per line;
   :func:`records` does steps 1 and 2);
3. per record type, :func:`numbers` converts the numeric bodies of all its lines in bulk and counts
   the tokens of every line from the raw bytes, so that a wrong field count or a non-numeric field
   is detected in bulk and then reported with the first offending line number (a slow per-line
   search runs only on that error path).

Python work per line is a few string operations; nothing runs per number. A file without a
single record or data row (empty, or only blank and comment lines) is a :class:`DataFormatError`
(``got 'no data line'``), never an empty dataset.

**How numbers are converted.** Tokens are found on the bytes (C ``isspace`` separates them, as in
numpy's parser), which gives every line's field count and so every error location. The tokens
themselves are converted by pandas' C parser (:func:`_pandas_values`): their text, every separator
turned into a line end, is read as one float64 column. pandas (fast_float; ``round_trip`` before
pandas 3.1) rounds correctly, so every value is the double ``strtod`` returns. pandas gets only text
made of ``[0-9+-.eE]`` tokens, on which it accepts exactly what ``float()`` accepts; every other text
(``nan``, ``inf``, a malformed token, garbage bytes), and any text pandas rejects, goes through
:func:`numpy.fromstring` as before, and a token that fails there is reported by the per-line
error path with its file and line. ``tests/datasets/test_text.py`` compares the result with numpy's
parser bit for bit on the staged MRCLAM and Intel files and with ``float()`` on generated decimals.
"""

from __future__ import annotations

import bz2
import csv
import gzip
import io
import lzma
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError

__all__ = [
    "read_bytes",
    "read_lines",
    "records",
    "binary_lines",
    "numeric_table",
    "check_finite",
    "check_unique",
    "integer_ids",
    "tags",
    "numbers",
    "fixed",
    "check_monotonic",
    "bodies_of",
    "symmetric_from_upper",
    "upper_triangular",
    "Lines",
]

_OPENERS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}


#: the UTF-8 byte order mark some editors (Notepad, Excel's "CSV UTF-8") put at the start of a text file
BOM = b"\xef\xbb\xbf"


def read_bytes(path: str | Path) -> bytes:
    """The (decompressed) content of a text file, a leading UTF-8 byte order mark removed (the one place every text
    reader reads through, so that a file saved "with BOM" reads as without)."""
    path = Path(path)
    opener = _OPENERS.get(path.suffix, open)
    try:
        with opener(path, "rb") as f:
            blob = f.read()
        return blob[len(BOM) :] if blob.startswith(BOM) else blob
    except (OSError, EOFError, lzma.LZMAError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise DataFormatError(path, None, f"a readable {path.suffix or 'text'} file", str(exc)) from exc


class Lines(list):
    """The lines of a file (without line ends) and the file's path, for error messages."""

    path: str

    def __init__(self, path: str | Path, lines: list[str]):
        super().__init__(lines)
        self.path = str(path)


def read_lines(path: str | Path) -> Lines:
    """All lines of a text file (latin-1, so that any byte sequence decodes).

    Lines end at ``\\n`` only (``\\r\\n`` accepted), so line numbers are those of an editor,
    not of :meth:`str.splitlines` (which also splits at form feeds and other separators).
    """
    text = read_bytes(path).decode("latin-1")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return Lines(path, [line[:-1] if line.endswith("\r") else line for line in lines] if "\r" in text else lines)


def tags(lines: list[str], comment: str = "#") -> np.ndarray:
    """First token of each line as a numpy string array; ``""`` for blank and comment lines."""
    first = [s[0] if (s := line.split(None, 1)) and not s[0].startswith(comment) else "" for line in lines]
    return np.array(first, dtype=str) if first else np.zeros(0, dtype="<U1")


#: what a file without a record or data row "got"
NO_DATA = "no data line"


def records(path: str | Path, what: str, comment: str = "#") -> tuple[Lines, np.ndarray]:
    """The lines of a record file and their :func:`tags`; a file without a record raises (``what``: a record)."""
    lines = read_lines(path)
    tag = tags(lines, comment)
    if not np.any(tag != ""):
        raise DataFormatError(lines.path, None, what, NO_DATA)
    return lines, tag


#: the bytes a text line may hold: printable ASCII, tab, carriage return (and the line end)
_TEXT_BYTES = bytes([9, 10, 13, *range(32, 127)])
_TEXT = np.zeros(256, dtype=bool)
_TEXT[list(_TEXT_BYTES)] = True


def binary_lines(lines: list[str]) -> np.ndarray:
    """0-based indices of the lines holding a byte no text line holds (:data:`_TEXT_BYTES`): binary garbage.

    One C pass (``bytes.translate``) decides that there is none; only then are the lines located.
    """
    blob = "\n".join(lines).encode("latin-1")
    if not blob.translate(None, _TEXT_BYTES):
        return np.zeros(0, dtype=np.int64)
    b = np.frombuffer(blob, dtype=np.uint8)
    return np.unique(np.searchsorted(np.flatnonzero(b == 10), np.flatnonzero(~_TEXT[b])))


_SPACE_BYTES = b"\t\n\x0b\x0c\r "
_SPACE = np.zeros(256, dtype=bool)
_SPACE[list(_SPACE_BYTES)] = True  # C isspace(), as numpy's parser


def _scan(b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start and end (exclusive) offsets of the whitespace-separated tokens of ``b``, and of its ``\\n`` bytes.

    One boolean work array serves every pass (fresh large temporaries cost a page fault per 4 KiB).
    """
    work = np.empty(2 * b.size + 3, dtype=bool)
    token, scratch = work[: b.size + 2], work[b.size + 2 :]  # token: b's bytes between two separators
    token[0] = token[-1] = False
    np.greater(b, 32, out=token[1:-1])
    below = [np.count_nonzero(np.less(b, c, out=scratch[1:])) for c in (9, 14, 32)]
    if below[2] - below[1] + below[0]:
        np.logical_not(_SPACE[b], out=token[1:-1])  # control characters other than \t\n\v\f\r belong to tokens
    newlines = np.flatnonzero(np.equal(b, 10, out=scratch[1:]))
    edges = np.flatnonzero(np.not_equal(token[1:], token[:-1], out=scratch))
    return edges[0::2], edges[1::2], newlines


#: what pandas is given: tokens of these characters only (every other text goes to numpy's parser)
_PLAIN = b"0123456789+-.eE"
#: every separator (C isspace) to a line end: the tokens become one column
_TO_LINES = bytes.maketrans(b" \t\x0b\x0c\r", b"\n" * 5)


def _pandas_values(text: bytes) -> np.ndarray | None:
    """The numbers of ``text`` (tokens of :data:`_PLAIN` characters) by pandas' C parser; ``None`` if it rejects one."""
    import pandas as pd

    precision = (
        {} if tuple(int(x) for x in pd.__version__.split(".")[:2]) >= (3, 1) else {"float_precision": "round_trip"}
    )
    try:
        column = pd.read_csv(
            io.BytesIO(text.translate(_TO_LINES)),
            header=None,
            names=[0],
            dtype=np.float64,
            engine="c",
            quoting=csv.QUOTE_NONE,
            na_filter=False,
            **precision,
        )
    except (ValueError, pd.errors.ParserError):
        return None
    return column[0].to_numpy()


def _parse_row(body: str | bytes) -> np.ndarray | None:
    """Numbers of a text through numpy's parser; ``None`` if it is not all numbers."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            values = np.fromstring(body, sep=" ") if body.strip() else np.zeros(0)
    except (ValueError, DeprecationWarning):
        return None
    return values


def _parse_tokens(
    blob: bytes, b: np.ndarray, starts: np.ndarray, ends: np.ndarray, run: bool = False
) -> np.ndarray | None:
    """The float64 value of every token ``blob[starts[i]:ends[i]]``; ``None`` if one is not a number.

    ``run``: the tokens are all the tokens of ``blob[starts[0]:ends[-1]]`` (one slice); otherwise the
    bytes outside the tokens are blanked. Text of :data:`_PLAIN` tokens goes to pandas, the rest (and
    what pandas rejects) to numpy's parser (module docstring).
    """
    if starts.size == 0:
        return np.zeros(0)
    if run:
        text = blob[starts[0] : ends[-1]]
    else:
        inside = np.zeros(b.size + 1, dtype=np.int64)
        inside[starts] += 1
        inside[ends] -= 1
        text = np.where(np.cumsum(inside[:-1]) > 0, b, np.uint8(32)).tobytes()
    values = None
    if not text.translate(None, _PLAIN + _SPACE_BYTES):
        values = _pandas_values(text)
    return _exactly(values if values is not None else _parse_row(text), starts.size)


def _exactly(values: np.ndarray | None, n: int) -> np.ndarray | None:
    """``values`` if numpy's parser read exactly ``n`` numbers, else ``None`` (the caller's error path)."""
    return values if values is not None and values.size == n else None


def _first_bad_token(bodies: list[str], counts: np.ndarray) -> tuple[int, str]:
    """(row, token) of the first record that does not parse to ``counts[row]`` numbers (error path only)."""
    for row, body in enumerate(bodies):
        values = _parse_row(body)
        if values is None or values.size != counts[row]:
            for token in body.split():
                if (v := _parse_row(token)) is None or v.size != 1:
                    return row, token
            return row, body[:80]
    return 0, bodies[0][:80] if bodies else ""


def numbers(
    path: str, bodies: list[str], line_numbers: np.ndarray, what: str, valid=None, expected: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """Parse the numeric ``bodies`` (one string per record) in bulk.

    Returns the flat float64 values and the number of fields of each record. ``valid(counts)``
    (optional) checks the field counts first, so that a truncated line is reported as such
    (``expected`` says what was expected); a non-numeric field raises at its line.
    """
    blob = "\n".join(bodies).encode("latin-1")
    b = np.frombuffer(blob, dtype=np.uint8)
    starts, ends, newlines = _scan(b)
    bounds = np.concatenate([[0], newlines + 1, [b.size]])[: len(bodies) + 1]
    counts = np.diff(np.searchsorted(starts, bounds))
    if valid is not None:
        bad = np.flatnonzero(~valid(counts))
        if bad.size:
            k = int(bad[0])
            raise DataFormatError(path, int(line_numbers[k]), expected, f"{counts[k]} fields: {bodies[k][:80].strip()}")
    values = _parse_tokens(blob, b, starts, ends, run=True)
    if values is None:
        row, token = _first_bad_token(bodies, counts)
        raise DataFormatError(path, int(line_numbers[row]), f"numeric fields in {what}", token)
    return values, counts


def fixed(path: str, bodies: list[str], line_numbers: np.ndarray, ncols: int, what: str) -> np.ndarray:
    """Parse records that each have exactly ``ncols`` numeric fields into an ``(N, ncols)`` array."""
    values, _ = numbers(path, bodies, line_numbers, what, lambda c: c == ncols, f"{ncols} numeric fields in {what}")
    return values.reshape(len(bodies), ncols)


def numeric_table(path: str | Path, ncols: int, what: str, comment: str = "#") -> tuple[np.ndarray, np.ndarray]:
    """A whitespace-separated numeric table (``comment`` lines and blank lines skipped), fully on bytes.

    Returns the ``(N, ncols)`` values (N ≥ 1) and the 1-based line number of each row. No Python code
    runs per line: line bounds, token counts and comment lines are found with numpy on the raw
    bytes, and the tokens of the data lines are converted in bulk.
    """
    blob = read_bytes(path)
    b = np.frombuffer(blob, dtype=np.uint8)
    starts, ends, newlines = _scan(b)
    line_start = np.concatenate([[0], newlines + 1])
    line_end = np.concatenate([newlines, [b.size]])
    if blob.endswith(b"\n"):
        line_start, line_end = line_start[:-1], line_end[:-1]
    first = np.searchsorted(starts, line_start)
    counts = np.diff(np.append(first, starts.size))  # no token lies between a line's end and the next line
    has = counts > 0
    lead = np.zeros(line_start.size, dtype=np.uint8)
    lead[has] = b[starts[first[has]]]
    data = has & (lead != ord(comment))
    rows = np.flatnonzero(data)
    if not rows.size:
        raise DataFormatError(path, None, what, NO_DATA)
    bad = np.flatnonzero(data & (counts != ncols))
    if bad.size:
        k = int(bad[0])
        got = blob[line_start[k] : line_end[k]].decode("latin-1")
        raise DataFormatError(
            path, k + 1, f"{ncols} numeric fields in {what}", f"{counts[k]} fields: {got[:80].strip()}"
        )
    k0 = first[rows[0]]
    run = first[rows[-1]] - k0 == (rows.size - 1) * ncols  # the data tokens are one run
    if run:
        starts, ends = starts[k0 : k0 + rows.size * ncols], ends[k0 : k0 + rows.size * ncols]
    else:  # comment lines between data lines: drop their tokens
        keep = np.repeat(data[has], counts[has])
        starts, ends = starts[keep], ends[keep]
    values = _parse_tokens(blob, b, starts, ends, run)
    if values is None:
        bodies = [blob[line_start[r] : line_end[r]].decode("latin-1") for r in rows]
        row, token = _first_bad_token(bodies, counts[rows])
        raise DataFormatError(path, int(rows[row]) + 1, f"numeric fields in {what}", token)
    return values.reshape(rows.size, ncols), rows + 1


def check_finite(path: str, values: np.ndarray, line_numbers: np.ndarray, what: str) -> None:
    """Raise at the first row of ``values`` (N, k) holding NaN or infinity (graph files: never valid)."""
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1)) if values.size else np.zeros(0, dtype=int)
    if bad.size:
        k = int(bad[0])
        raise DataFormatError(path, int(line_numbers[k]), f"finite numbers in {what}", str(values[k].tolist()))


def integer_ids(path: str | Path, values: np.ndarray, line_numbers: np.ndarray, what: str = "ids") -> np.ndarray:
    """``values`` (N,) or (N, k) as int64; raise at the first row holding a value that is not a non-negative integer
    (a barcode 14.5 is not 14: truncating would name another subject)."""
    v = np.asarray(values, dtype=float)
    bad = ~((v == np.round(v)) & (v >= 0))
    rows = np.flatnonzero(bad.any(axis=1) if v.ndim > 1 else bad)
    if rows.size:
        k = int(rows[0])
        raise DataFormatError(path, int(line_numbers[k]), f"non-negative integer {what}", str(v[k].tolist()))
    return v.astype(np.int64)


def check_unique(path: str, ids: np.ndarray, line_numbers: np.ndarray, what: str) -> None:
    """Raise at the first line whose id ``ids`` (N,) was declared on an earlier line."""
    _, first = np.unique(ids, return_index=True)
    if first.size != ids.size:
        k = int(np.setdiff1d(np.arange(ids.size), first)[0])
        earlier = int(line_numbers[np.flatnonzero(ids == ids[k])[0]])
        raise DataFormatError(
            path, int(line_numbers[k]), f"unique {what} ids (also declared on line {earlier})", str(ids[k])
        )


def check_monotonic(path: str, t: np.ndarray, line_numbers: np.ndarray, what: str) -> None:
    """Raise at the first line whose time is smaller than the previous one, or not finite."""
    nonfinite = np.flatnonzero(~np.isfinite(t))
    if nonfinite.size:
        k = int(nonfinite[0])
        raise DataFormatError(path, int(line_numbers[k]), f"a finite time in {what}", str(t[k]))
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise DataFormatError(
            path, int(line_numbers[k]), f"non-decreasing time in {what} (previous {t[k - 1]!r})", str(t[k])
        )


def bodies_of(lines: list[str], rows: np.ndarray, skip: int = 1) -> list[str]:
    """The text of ``lines[rows]`` after the first ``skip`` tokens (the record tag)."""
    if skip == 0:
        return [lines[r] for r in rows]
    return [parts[skip] if len(parts := lines[r].split(None, skip)) > skip else "" for r in rows]


def record_values(lines: Lines, rows: np.ndarray, ncols: int, what: str) -> np.ndarray:
    """The ``ncols`` numbers after the tag of each line ``rows`` (0-based), all finite.

    A wrong field count, a non-numeric field or a non-finite number raises
    :class:`DataFormatError` naming the first offending line.
    """
    values = fixed(lines.path, bodies_of(lines, rows), rows + 1, ncols, what)
    check_finite(lines.path, values, rows + 1, what)
    return values


def symmetric_from_upper(values: np.ndarray, n: int) -> np.ndarray:
    """Symmetric ``(K, n, n)`` matrices from row-major upper triangles ``(K, n(n+1)/2)``."""
    rows, cols = np.triu_indices(n)
    out = np.zeros((values.shape[0], n, n))
    out[:, rows, cols] = values
    out[:, cols, rows] = values
    return out


def upper_triangular(values: np.ndarray, n: int) -> np.ndarray:
    """Upper-triangular ``(K, n, n)`` matrices (zero below the diagonal) from row-major upper triangles ``(K, n(n+1)/2)``
    (:func:`symmetric_from_upper` mirrors them instead)."""
    rows, cols = np.triu_indices(n)
    out = np.zeros((values.shape[0], n, n))
    out[:, rows, cols] = values
    return out
