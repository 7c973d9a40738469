"""PLY point clouds: ``binary_little_endian`` and ``ascii`` (vertex element, scalar properties).

:func:`read` returns the vertex properties as a dict ``name → (N,) array`` (in file order) and
:func:`points` the ``(N, 3)`` x, y, z. Elements other than ``vertex`` are allowed after the
vertices in ASCII files and ignored (counted in the result's ``"_ignored_elements"``); list
properties are not supported (an error says so). A cloud without a vertex is an error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from ._text import numbers

__all__ = ["read", "points", "write"]

TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


def _header(path: Path, data: bytes):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise DataFormatError(path, 1, "a PLY header ('ply' … 'end_header')", data[:20].decode("latin-1"))
    body_start = data.index(b"\n", end) + 1
    header = data[:end].decode("latin-1").splitlines()
    fmt = None
    elements: list[tuple[str, int, list[tuple[str, str]]]] = []
    for number, line in enumerate(header, 1):
        parts = line.split()
        if not parts or parts[0] in ("ply", "comment", "obj_info"):
            continue
        if parts[0] == "format":
            if len(parts) < 2 or parts[1] not in ("ascii", "binary_little_endian"):
                raise DataFormatError(path, number, "format ascii or binary_little_endian", line)
            fmt = parts[1]
        elif parts[0] == "element":
            if len(parts) != 3 or not parts[2].isdigit():
                raise DataFormatError(path, number, "element NAME COUNT", line)
            elements.append((parts[1], int(parts[2]), []))
        elif parts[0] == "property":
            if not elements:
                raise DataFormatError(path, number, "a property after an element", line)
            if len(parts) != 3 or parts[1] not in TYPES:
                raise DataFormatError(path, number, f"property TYPE NAME with TYPE in {sorted(TYPES)} (no lists)", line)
            elements[-1][2].append((parts[2], TYPES[parts[1]]))
        else:
            raise DataFormatError(path, number, "a PLY header keyword", line)
    if fmt is None:
        raise DataFormatError(path, None, "a 'format' line in the header", "none")
    if not elements or elements[0][0] != "vertex":
        raise DataFormatError(path, None, "the vertex element first", str([e[0] for e in elements]))
    return fmt, elements, body_start, len(header) + 1


def read(path: str | Path) -> dict:
    path = Path(path)
    data = path.read_bytes()
    fmt, elements, start, header_lines = _header(path, data)
    _, n, props = elements[0]
    if n == 0:
        raise DataFormatError(path, None, "at least one vertex", "element vertex 0")
    if fmt == "binary_little_endian":
        dtype = np.dtype([(name, "<" + t) for name, t in props])
        need = n * dtype.itemsize
        if len(data) - start < need:
            raise DataFormatError(path, None, f"{n} vertices of {dtype.itemsize} bytes", f"{len(data) - start} bytes")
        table = np.frombuffer(data, dtype=dtype, count=n, offset=start)
        out = {name: np.array(table[name]) for name, _ in props}
    else:
        lines = data[start:].decode("latin-1").splitlines()
        if len(lines) < n:
            raise DataFormatError(path, header_lines + len(lines), f"{n} vertex lines", f"{len(lines)}")
        line_numbers = header_lines + 1 + np.arange(n)
        values, _ = numbers(
            str(path),
            lines[:n],
            line_numbers,
            "a PLY vertex line",
            lambda c: c == len(props),
            f"{len(props)} vertex properties",
        )
        table = values.reshape(n, len(props))
        out = {name: table[:, k].astype(t) for k, (name, t) in enumerate(props)}
    out["_ignored_elements"] = [e[0] for e in elements[1:]]
    return out


def points(path: str | Path) -> np.ndarray:
    """The ``(N, 3)`` float64 vertex positions."""
    v = read(path)
    return np.column_stack([v["x"], v["y"], v["z"]]).astype(np.float64)


def write(path: str | Path, properties: dict, binary: bool = True) -> None:
    """Write vertex properties (name → (N,) array; float32/float64/int types kept)."""
    names = [k for k in properties if not k.startswith("_")]
    arrays = [np.asarray(properties[k]) for k in names]
    inverse = {
        v: k for k, v in TYPES.items() if k in ("char", "uchar", "short", "ushort", "int", "uint", "float", "double")
    }
    kinds = [inverse[a.dtype.str[1:]] for a in arrays]
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {len(arrays[0])}"]
    header += [f"property {k} {n}" for k, n in zip(kinds, names)] + ["end_header"]
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode())
        if binary:
            table = np.empty(len(arrays[0]), dtype=[(n, "<" + a.dtype.str[1:]) for n, a in zip(names, arrays)])
            for n, a in zip(names, arrays):
                table[n] = a
            f.write(table.tobytes())
        else:
            np.savetxt(f, np.column_stack(arrays), fmt="%.9g")
