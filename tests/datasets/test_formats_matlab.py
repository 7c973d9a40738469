"""MAT-file (Level 5) reader against scipy.io, on the staged Plaza files and on files written here."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
import scipy.io

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats.matlab import read_mat
from checks import staged

ARRAYS = {
    "double": np.arange(12.0).reshape(3, 4) - 5.5,
    "small_ints_as_double": np.array([[1.0, 2.0, 300.0]]),  # MATLAB/scipy may store these narrower
    "int16": np.array([[1, -2], [3, 4]], dtype=np.int16),
    "uint32_3d": np.arange(24, dtype=np.uint32).reshape(2, 3, 4),
    "single": np.float32([[1.5, -2.25]]),
    "complex": np.array([[1 + 2j, 3 - 1j]]),
    "empty": np.zeros((0, 3)),
    "scalar": np.array([[7.0]]),
}


@pytest.mark.realdata
@pytest.mark.parametrize("run", ["Plaza1", "Plaza2"])
def test_staged_plaza_files_match_scipy(run):
    path = staged(f"plaza_range_only/{run}_.mat")
    ours, ref = read_mat(path), scipy.io.loadmat(path)
    assert set(ours) == {"GT", "DR", "DRp", "TD", "TL"} == {k for k in ref if not k.startswith("__")}
    for name, value in ours.items():
        assert value.dtype == ref[name].dtype and np.array_equal(value, ref[name])
    assert set(read_mat(path, ("TL",))) == {"TL"}


@pytest.mark.parametrize("compress", [False, True])
def test_round_trip_through_scipy_savemat(tmp_path, compress):
    path = tmp_path / "arrays.mat"
    scipy.io.savemat(path, {**ARRAYS, "flags": np.array([[True, False]])}, do_compression=compress)
    ours, ref = read_mat(path), scipy.io.loadmat(path)
    for name in ARRAYS:
        assert ours[name].dtype == ref[name].dtype and ours[name].shape == ref[name].shape
        assert np.array_equal(ours[name], ref[name])
    assert ours["flags"].dtype == bool and ours["flags"].tolist() == [[True, False]]


def _element(kind: int, payload: bytes, order: str) -> bytes:
    return struct.pack(order + "II", kind, len(payload)) + payload + b"\0" * (-len(payload) % 8)


def _matrix(name: str, values: np.ndarray, order: str, mx_class: int = 6) -> bytes:
    """One miMATRIX element written by hand (values column-major, stored as miDOUBLE)."""
    flags = _element(6, struct.pack(order + "II", mx_class, 0), order)
    dims = _element(5, struct.pack(order + "ii", *values.shape), order)
    name_el = struct.pack(order + "HH", len(name), 1) + name.encode() + b"\0" * (4 - len(name)) if len(name) <= 4 else _element(1, name.encode(), order)
    real = _element(9, values.astype(order + "f8").tobytes(order="F"), order)
    return _element(14, flags + dims + name_el + real, order)


def _header(order: str, version: int = 0x0100) -> bytes:
    text = b"MATLAB 5.0 MAT-file, written by the slamarena tests".ljust(116)
    return text + b"\0" * 8 + struct.pack(order + "H", version) + (b"IM" if order == "<" else b"MI")


@pytest.mark.parametrize("order", ["<", ">"])
def test_hand_written_file_in_either_byte_order(tmp_path, order):
    a = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    body = _matrix("A", a, order) + _matrix("long_name", a.T, order)
    packed = zlib.compress(_matrix("Z", -a, order))
    compressed = struct.pack(order + "II", 15, len(packed)) + packed  # miCOMPRESSED: no padding after the stream
    path = tmp_path / "hand.mat"
    path.write_bytes(_header(order) + body + compressed)
    out = read_mat(path)
    assert np.array_equal(out["A"], a) and np.array_equal(out["long_name"], a.T) and np.array_equal(out["Z"], -a)
    if order == "<":
        ref = scipy.io.loadmat(path)
        assert np.array_equal(ref["A"], a) and np.array_equal(ref["Z"], -a)  # the hand-written file is valid


def test_bad_files_raise_a_clear_error(tmp_path):
    a = np.eye(2)
    cases = {
        "short.mat": (b"MATLAB", "a MAT-file header of 128 bytes"),
        "v73.mat": (_header("<", 0x0200) + _matrix("A", a, "<"), "version 0x0100"),
        "text.mat": (b"x" * 200, "endian indicator"),
        "truncated.mat": ((_header("<") + _matrix("A", a, "<"))[:-20], "bytes of element data"),
        "badzlib.mat": (_header("<") + struct.pack("<II", 15, 8) + b"notzlib!", "a zlib stream"),
    }
    for name, (content, message) in cases.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(DataFormatError, match=message) as info:
            read_mat(tmp_path / name)
        assert name in str(info.value)
    (tmp_path / "cell.mat").write_bytes(_header("<") + _matrix("C", a, "<", mx_class=1) + _matrix("A", a, "<"))
    assert np.array_equal(read_mat(tmp_path / "cell.mat", ("A",))["A"], a)  # the cell is skipped unread
    with pytest.raises(DataFormatError, match="numeric matrix for variable 'C', got 'a cell array'"):
        read_mat(tmp_path / "cell.mat")
    with pytest.raises(DataFormatError, match="variable\\(s\\) B, got 'variables C, A'"):
        read_mat(tmp_path / "cell.mat", ("A", "B"))
