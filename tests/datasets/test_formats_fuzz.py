"""Property tests: random text fed to every line-based reader raises nothing but DataFormatError."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import _text, carmen, g2o, isam, mrclam, relations, toro, tum, victoria_park

NUMBERS = st.one_of(
    st.integers(-3, 12).map(str),
    st.floats(allow_nan=True, allow_infinity=True, width=32).map(lambda x: f"{x:g}"),
    st.sampled_from(["0", "1", "1e3", "-0.5", "nan", "inf", "1-2", "0x10", "1.2.3", "", "e5", "+", ".", "--1"]),
)
GARBAGE = st.text(alphabet=st.characters(codec="latin-1", exclude_characters="\r\n"), max_size=8)
TAGS = [
    "ODOM",
    "FLASER",
    "ROBOTLASER1",
    "PARAM",
    "NEFF",
    "VERTEX_SE2",
    "EDGE_SE2",
    "VERTEX_XY",
    "EDGE_SE2_XY",
    "VERTEX_SE3:QUAT",
    "EDGE_SE3:QUAT",
    "FIX",
    "VERTEX2",
    "EDGE2",
    "EQUIV",
    "BR",
    "ODOMETRY",
    "LANDMARK",
    "#",
]


@st.composite
def record_line(draw):
    tag = draw(st.one_of(st.sampled_from(TAGS), st.just(""), GARBAGE))
    n = draw(st.integers(0, 14))
    fields = draw(st.lists(st.one_of(NUMBERS, NUMBERS, NUMBERS, GARBAGE), min_size=n, max_size=n))
    if tag in ("FLASER",) and fields and draw(st.booleans()):
        fields[0] = str(max(len(fields) - 9, 0))
    sep = draw(st.sampled_from([" ", "\t", "  ", " \t "]))
    return sep.join([tag, *fields])


#: field counts of well-formed records (ids first), so that the fuzzer also reaches the semantic checks
FIELDS = {
    "VERTEX_SE2": (1, 3),
    "EDGE_SE2": (2, 9),
    "VERTEX_XY": (1, 2),
    "EDGE_SE2_XY": (2, 5),
    "VERTEX2": (1, 3),
    "EDGE2": (2, 9),
    "EQUIV": (2, 0),
    "BR": (2, 4),
    "ODOMETRY": (2, 9),
    "LANDMARK": (2, 5),
    "VERTEX_SE3:QUAT": (1, 7),
    "EDGE_SE3:QUAT": (2, 28),
    "ODOM": (0, 9),
    "FIX": (1, 0),
}


@st.composite
def well_formed_line(draw):
    tag = draw(st.sampled_from(sorted(FIELDS)))
    ids, rest = FIELDS[tag]
    fields = [str(draw(st.integers(0, 3))) for _ in range(ids)] + draw(
        st.lists(NUMBERS.filter(bool), min_size=rest, max_size=rest)
    )
    return " ".join([tag, *fields])


FILES = st.lists(st.one_of(record_line(), well_formed_line()), max_size=12).map(lambda lines: "\n".join(lines) + "\n")
FUZZ = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_bytes(text.encode("latin-1"))
    return path


READERS = {
    "g2o": lambda p: g2o.read(p),
    "toro": lambda p: toro.read(p),
    "isam": lambda p: isam.read(p),
    "victoria_park": lambda p: victoria_park.read(p),
    "victoria_park_gtsam": lambda p: victoria_park.read(p, "gtsam"),
    "carmen": lambda p: carmen.read(p),
    "carmen_corrected": lambda p: carmen.read(p, corrected=True),
    "relations": lambda p: relations.read(p),
    "tum": lambda p: tum.read(p),
    "mrclam_table": lambda p: mrclam.read_table(p, 4, "a row"),
}


@pytest.mark.parametrize("reader", list(READERS))
@FUZZ
@given(text=FILES)
def test_readers_raise_only_data_format_errors(tmp_path, reader, text):
    path = _write(tmp_path, "fuzz.txt", text)
    try:
        READERS[reader](path)
    except DataFormatError as err:
        assert str(path) in str(err)
        assert err.line is None or 1 <= err.line <= text.count("\n")


# Python's float() and numpy's C parser differ only on "1_000" and "nan(…)": kept out of this oracle test
ASCII_GARBAGE = st.text(alphabet="abcdefxyzEINAF0123456789.+-,;:/ \t", max_size=6)


@settings(max_examples=100, deadline=None)
@given(
    rows=st.lists(st.lists(st.one_of(NUMBERS, ASCII_GARBAGE), min_size=0, max_size=5), min_size=1, max_size=8),
    ncols=st.integers(1, 5),
)
def test_fixed_parser_agrees_with_python_float(rows, ncols):
    """The bulk parser accepts exactly the rows Python's float() accepts with the right field count."""
    bodies = [" ".join(r) for r in rows]
    tokens = [b.split() for b in bodies]  # ASCII only: Python's and C's whitespace agree

    def ok(t):
        try:
            [float(x) for x in t]
        except ValueError:
            return False
        return len(t) == ncols

    try:
        values = _text.fixed("mem", bodies, np.arange(1, len(bodies) + 1), ncols, "a row")
    except DataFormatError as err:
        # field counts are checked first (a truncated line is reported as such), then the numbers
        wrong_count = [k for k, t in enumerate(tokens) if len(t) != ncols]
        first_bad = wrong_count[0] if wrong_count else next(k for k, t in enumerate(tokens) if not ok(t))
        assert err.line == first_bad + 1
    else:
        assert all(ok(t) for t in tokens)
        expected = np.array([[float(x) for x in t] for t in tokens]).reshape(len(tokens), ncols)
        assert np.array_equal(values, expected, equal_nan=True)
