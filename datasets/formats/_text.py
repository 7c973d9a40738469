"""Vectorised parsing of whitespace-separated text records, with exact error locations.

Every text reader of :mod:`datasets.formats` works the same way:

1. :func:`read_lines` reads the whole (optionally ``.gz``/``.bz2``-compressed) file and splits it
   into lines once;
2. :func:`tags` takes the first token of every line (one cheap string operation per line);
3. per record type, :func:`numbers` converts the numeric bodies of all its lines in ONE call to
   numpy's C parser and counts the tokens of every line from the raw bytes, so that a wrong field
   count or a non-numeric field is detected in bulk and then reported with the first offending
   line number (a slow per-line search runs only on that error path).

Python work per line is a few string operations; nothing runs per number.
"""
from __future__ import annotations

import bz2
import gzip
import lzma
import warnings
from pathlib import Path

import numpy as np

from ..errors import DataFormatError

__all__ = ["read_bytes", "read_lines", "numeric_table", "check_finite", "tags", "numbers", "fixed", "check_monotonic", "bodies_of", "upper_triangle", "upper_triangular", "Lines"]

_OPENERS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}


def read_bytes(path: str | Path) -> bytes:
    """The (decompressed) content of a file."""
    path = Path(path)
    opener = _OPENERS.get(path.suffix, open)
    try:
        with opener(path, "rb") as f:
            return f.read()
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


_SPACE = np.zeros(256, dtype=bool)
_SPACE[[9, 10, 11, 12, 13, 32]] = True  # C isspace(), as numpy's parser


def _token_counts(blob: bytes, n_lines: int) -> np.ndarray:
    """Whitespace-separated tokens per line of ``blob`` (lines joined by ``\\n``), vectorised."""
    if n_lines == 0:
        return np.zeros(0, dtype=np.int64)
    b = np.frombuffer(blob, dtype=np.uint8)
    space = _SPACE[b]
    starts = ~space
    starts[1:] &= space[:-1]
    first_token = np.flatnonzero(starts)
    bounds = np.concatenate([[0], np.flatnonzero(b == 10) + 1, [b.size]])[: n_lines + 1]
    return np.diff(np.searchsorted(first_token, bounds))


def _parse_row(body: str) -> np.ndarray | None:
    """One record through numpy's parser; ``None`` if it is not all numbers."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            values = np.fromstring(body, sep=" ") if body.strip() else np.zeros(0)
    except (ValueError, DeprecationWarning):
        return None
    return values


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


def numbers(path: str, bodies: list[str], line_numbers: np.ndarray, what: str, valid=None, expected: str = "") -> tuple[np.ndarray, np.ndarray]:
    """Parse the numeric ``bodies`` (one string per record) in bulk.

    Returns the flat float64 values and the number of fields of each record. ``valid(counts)``
    (optional) checks the field counts first, so that a truncated line is reported as such
    (``expected`` says what was expected); a non-numeric field raises at its line.
    """
    text = "\n".join(bodies)
    counts = _token_counts(text.encode("latin-1"), len(bodies))
    if valid is not None:
        bad = np.flatnonzero(~valid(counts))
        if bad.size:
            k = int(bad[0])
            raise DataFormatError(path, int(line_numbers[k]), expected, f"{counts[k]} fields: {bodies[k][:80].strip()}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            values = np.fromstring(text, sep=" ") if counts.sum() else np.zeros(0)
        ok = values.size == counts.sum()
    except (ValueError, DeprecationWarning):
        ok = False
    if not ok:
        row, token = _first_bad_token(bodies, counts)
        raise DataFormatError(path, int(line_numbers[row]), f"numeric fields in {what}", token)
    return values, counts


def fixed(path: str, bodies: list[str], line_numbers: np.ndarray, ncols: int, what: str) -> np.ndarray:
    """Parse records that each have exactly ``ncols`` numeric fields into an ``(N, ncols)`` array."""
    values, _ = numbers(path, bodies, line_numbers, what, lambda c: c == ncols, f"{ncols} numeric fields in {what}")
    return values.reshape(len(bodies), ncols)


def numeric_table(path: str | Path, ncols: int, what: str, comment: str = "#") -> tuple[np.ndarray, np.ndarray]:
    """A whitespace-separated numeric table (``comment`` lines and blank lines skipped), fully on bytes.

    Returns the ``(N, ncols)`` values and the 1-based line number of each row. No Python code
    runs per line: line bounds, token counts and comment lines are found with numpy on the raw
    bytes, and the data lines go through numpy's parser in one call.
    """
    blob = read_bytes(path)
    b = np.frombuffer(blob, dtype=np.uint8)
    space = _SPACE[b]
    starts = ~space
    starts[1:] &= space[:-1]
    first_token = np.flatnonzero(starts)
    newlines = np.flatnonzero(b == 10)
    line_start = np.concatenate([[0], newlines + 1])
    line_end = np.concatenate([newlines, [b.size]])
    if blob.endswith(b"\n"):
        line_start, line_end = line_start[:-1], line_end[:-1]
    first = np.searchsorted(first_token, line_start)
    counts = np.searchsorted(first_token, line_end) - first
    has = counts > 0
    lead = np.zeros(line_start.size, dtype=np.uint8)
    lead[has] = b[first_token[first[has]]]
    data = has & (lead != ord(comment))
    rows = np.flatnonzero(data)
    bad = np.flatnonzero(data & (counts != ncols))
    if bad.size:
        k = int(bad[0])
        got = blob[line_start[k]:line_end[k]].decode("latin-1")
        raise DataFormatError(path, k + 1, f"{ncols} numeric fields in {what}", f"{counts[k]} fields: {got[:80].strip()}")
    # contiguous runs of data lines, joined without the comment lines between them
    edges = np.flatnonzero(np.diff(np.concatenate([[0], data.astype(np.int8), [0]])))
    text = b"\n".join(blob[line_start[a]:line_end[z - 1]] for a, z in zip(edges[::2], edges[1::2])).decode("latin-1")
    values = _parse_row(text) if rows.size else np.zeros(0)
    if values is None or values.size != rows.size * ncols:
        bodies = [blob[line_start[r]:line_end[r]].decode("latin-1") for r in rows]
        row, token = _first_bad_token(bodies, counts[rows])
        raise DataFormatError(path, int(rows[row]) + 1, f"numeric fields in {what}", token)
    return values.reshape(rows.size, ncols), rows + 1


def check_finite(path: str, values: np.ndarray, line_numbers: np.ndarray, what: str) -> None:
    """Raise at the first row of ``values`` (N, k) holding NaN or infinity (graph files: never valid)."""
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1)) if values.size else np.zeros(0, dtype=int)
    if bad.size:
        k = int(bad[0])
        raise DataFormatError(path, int(line_numbers[k]), f"finite numbers in {what}", str(values[k].tolist()))


def check_monotonic(path: str, t: np.ndarray, line_numbers: np.ndarray, what: str) -> None:
    """Raise at the first line whose time is smaller than the previous one, or not finite."""
    nonfinite = np.flatnonzero(~np.isfinite(t))
    if nonfinite.size:
        k = int(nonfinite[0])
        raise DataFormatError(path, int(line_numbers[k]), f"a finite time in {what}", str(t[k]))
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise DataFormatError(path, int(line_numbers[k]), f"non-decreasing time in {what} (previous {t[k - 1]!r})", str(t[k]))


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


def upper_triangle(values: np.ndarray, n: int) -> np.ndarray:
    """Symmetric ``(K, n, n)`` matrices from row-major upper triangles ``(K, n(n+1)/2)``."""
    rows, cols = np.triu_indices(n)
    out = np.zeros((values.shape[0], n, n))
    out[:, rows, cols] = values
    out[:, cols, rows] = values
    return out


def upper_triangular(values: np.ndarray, n: int) -> np.ndarray:
    """Upper-triangular ``(K, n, n)`` matrices (zero below the diagonal) from row-major triangles."""
    rows, cols = np.triu_indices(n)
    out = np.zeros((values.shape[0], n, n))
    out[:, rows, cols] = values
    return out
