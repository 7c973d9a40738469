"""Numeric matrices from MATLAB Level 5 MAT-files (``save -v6`` / ``-v7``), in numpy and zlib.

The data layer depends on numpy and the standard library only, so it cannot call
``scipy.io.loadmat``; the few datasets that ship ``.mat`` files (CMU Plaza) hold plain real
matrices, which this reader covers. The format (MathWorks, "MAT-File Format", Level 5):

- a 128-byte header: 116 bytes of text, 8 bytes of subsystem offset, the version ``0x0100``
  and the endian indicator ``"IM"`` (little-endian file) or ``"MI"`` (big-endian);
- then data elements, each an 8-byte tag ``(type: uint32, nbytes: uint32)`` followed by
  ``nbytes`` of data padded to a multiple of 8 — or, when ``nbytes <= 4``, the "small element"
  form that packs ``(nbytes: uint16, type: uint16)`` and the data into the 8 tag bytes;
- a variable is an ``miMATRIX`` element (14), possibly wrapped in an ``miCOMPRESSED`` element
  (15: a zlib stream holding one ``miMATRIX``). Its sub-elements are the array flags (class in
  the low byte, complex flag ``0x0800``), the dimensions (``int32``), the name and the real part
  (then the imaginary part if complex). The stored type of the data may be narrower than the
  class (MATLAB writes a double matrix of small integers as ``uint8``); values are converted to
  the class's dtype. Data are column-major.

Read: real and complex numeric classes (double, single, int8 … uint64) and ``logical``, any
number of dimensions, either byte order. Anything else (cell, struct, object, char, sparse, the
HDF5-based v7.3 format) raises :class:`~slamarena.datasets.errors.DataFormatError` when that variable is
asked for; other variables in the file are skipped unread.
"""
from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from ..errors import DataFormatError

__all__ = ["read_mat"]

#: data element types → numpy dtype (without byte order)
_MI_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 9: "f8", 12: "i8", 13: "u8"}
_MI_MATRIX, _MI_COMPRESSED = 14, 15
#: array classes → numpy dtype of the values
_MX_NUMERIC = {6: "f8", 7: "f4", 8: "i1", 9: "u1", 10: "i2", 11: "u2", 12: "i4", 13: "u4", 14: "i8", 15: "u8"}
_MX_NAMES = {1: "cell", 2: "struct", 3: "object", 4: "char", 5: "sparse", 16: "function handle", 17: "opaque"}
_COMPLEX, _LOGICAL = 0x0800, 0x0200


class _Reader:
    """Walks the data elements of one byte buffer (the file body, or a decompressed element)."""

    def __init__(self, path: str, data: bytes, order: str):
        self.path, self.data, self.order = path, data, order

    def tag(self, pos: int) -> tuple[int, int, int, int]:
        """(type, nbytes, start of data, start of the next element) of the element at ``pos``."""
        if pos + 8 > len(self.data):
            raise DataFormatError(self.path, None, f"a data element tag at byte {pos}", "end of data")
        first, second = np.frombuffer(self.data, dtype=self.order + "u4", count=2, offset=pos).tolist()
        if first >> 16:  # small data element: nbytes and type share the first word, data in the second
            return first & 0xFFFF, first >> 16, pos + 4, pos + 8
        end = pos + 8 + second
        if end > len(self.data):
            raise DataFormatError(self.path, None, f"{second} bytes of element data at byte {pos}", f"{len(self.data) - pos - 8}")
        return first, second, pos + 8, end if first == _MI_COMPRESSED else end + (-second % 8)

    def values(self, pos: int) -> tuple[np.ndarray, int]:
        """The numeric array of the element at ``pos`` and the position after it."""
        kind, nbytes, start, after = self.tag(pos)
        if kind not in _MI_TYPES:
            raise DataFormatError(self.path, None, f"a numeric data element at byte {pos}", f"type {kind}")
        dtype = np.dtype(self.order + _MI_TYPES[kind])
        if nbytes % dtype.itemsize:
            raise DataFormatError(self.path, None, f"a whole number of {dtype.name} values at byte {pos}", f"{nbytes} bytes")
        return np.frombuffer(self.data, dtype=dtype, count=nbytes // dtype.itemsize, offset=start), after

    def matrix(self, start: int, wanted) -> tuple[str, np.ndarray | None]:
        """Name and value of the miMATRIX whose data start at ``start`` (value None if not ``wanted(name)``)."""
        flags, pos = self.values(start)
        dims, pos = self.values(pos)
        name_bytes, pos = self.values(pos)
        name = name_bytes.tobytes().decode("latin-1")
        if not wanted(name):
            return name, None
        mx, complex_ = int(flags[0]) & 0xFF, bool(int(flags[0]) & _COMPLEX)
        if mx not in _MX_NUMERIC:
            raise DataFormatError(self.path, None, f"a numeric matrix for variable {name!r}", f"a {_MX_NAMES.get(mx, f'class {mx}')} array")
        shape = tuple(int(d) for d in dims)
        real, pos = self.values(pos)
        value = real.astype(_MX_NUMERIC[mx])
        if complex_:
            imag, _ = self.values(pos)
            value = value + 1j * imag.astype(_MX_NUMERIC[mx])
        if value.size != int(np.prod(shape)):
            raise DataFormatError(self.path, None, f"{int(np.prod(shape))} values for {name!r} of shape {shape}", str(value.size))
        value = value.reshape(shape, order="F")
        return name, value.astype(bool) if int(flags[0]) & _LOGICAL else value


def read_mat(path: str | Path, names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The numeric variables of a Level 5 MAT-file (all, or those in ``names``) as numpy arrays.

    Shapes are MATLAB's (at least 2-D); a variable in ``names`` that the file lacks raises
    :class:`DataFormatError` naming the variables it has.
    """
    path = str(path)
    blob = Path(path).read_bytes()
    if len(blob) < 128:
        raise DataFormatError(path, None, "a MAT-file header of 128 bytes", f"{len(blob)} bytes")
    indicator = blob[126:128]
    if indicator not in (b"IM", b"MI"):
        raise DataFormatError(path, None, "a MATLAB Level 5 MAT-file (endian indicator 'IM' or 'MI')", repr(indicator))
    order = "<" if indicator == b"IM" else ">"
    version = int(np.frombuffer(blob, dtype=order + "u2", count=1, offset=124)[0])
    if version != 0x0100:
        raise DataFormatError(path, None, "MAT-file version 0x0100 (save -v7 or -v6; -v7.3 is HDF5)", hex(version))
    wanted = (lambda name: True) if names is None else (lambda name: name in names)
    out: dict[str, np.ndarray] = {}
    seen: list[str] = []
    body = _Reader(path, blob, order)
    pos = 128
    while pos < len(blob):
        kind, nbytes, start, after = body.tag(pos)
        if kind == _MI_COMPRESSED:
            try:
                inner = _Reader(path, zlib.decompress(blob[start:start + nbytes]), order)
            except zlib.error as exc:
                raise DataFormatError(path, None, f"a zlib stream in the element at byte {pos}", str(exc)) from exc
            kind, _, inner_start, _ = inner.tag(0)
            reader, start = inner, inner_start
        else:
            reader = body
        if kind == _MI_MATRIX:
            name, value = reader.matrix(start, wanted)
            seen.append(name)
            if value is not None:
                out[name] = value
        pos = after
    missing = [n for n in (names or ()) if n not in out]
    if missing:
        raise DataFormatError(path, None, f"variable(s) {', '.join(missing)}", f"variables {', '.join(seen) or '(none)'}")
    return out
