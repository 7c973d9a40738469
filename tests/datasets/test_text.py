"""The bulk number parser of slamarena.datasets.formats._text: bit-identical to numpy's parser and to float().

pandas' C parser (:func:`_text._pandas_values`, given only text of ``[0-9+-.eE]`` tokens) must give the
same float64 bits as ``strtod`` and accept exactly the tokens ``float()`` accepts; everything else goes
through numpy's parser unchanged.
"""

from __future__ import annotations

from itertools import compress

import numpy as np
import pytest
from checks import staged
from hypothesis import given, settings
from hypothesis import strategies as st

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import _text

MRCLAM6 = "utias_mrclam/MRCLAM_Dataset6"
STAGED = [
    f"{MRCLAM6}/Robot{k}_{kind}.dat.gz" for k in range(1, 6) for kind in ("Odometry", "Measurement", "Groundtruth")
]
STAGED += [f"{MRCLAM6}/Barcodes.dat", f"{MRCLAM6}/Landmark_Groundtruth.dat", "radish_laser_logs/intel.clf.bz2"]


def bits(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float64).view(np.int64)


# ----------------------------------------------------------------- the staged real files


@pytest.mark.parametrize("relpath", STAGED)
def test_staged_files_bit_identical_to_numpy(relpath):
    """Every number of the real file: same bits as np.fromstring, and all via pandas."""
    blob = _text.read_bytes(staged(relpath))
    b = np.frombuffer(blob, dtype=np.uint8)
    starts, ends, newlines = _text._scan(b)
    assert np.array_equal(newlines, np.flatnonzero(b == 10))
    tokens = blob.split()
    assert len(tokens) == starts.size and tokens[-1] == blob[starts[-1] : ends[-1]]
    numeric = np.isin(b[starts], np.frombuffer(b"+-.0123456789", dtype=np.uint8))  # not tags, host names, comments
    starts, ends = starts[numeric], ends[numeric]
    expected = np.fromstring(b" ".join(compress(tokens, numeric.tolist())), sep=" ")
    values = _text._parse_tokens(blob, b, starts, ends)
    assert values is not None and values.size == expected.size > 0
    assert np.array_equal(bits(values), bits(expected))
    pandas = _text._pandas_values(b" ".join(compress(tokens, numeric.tolist())))
    assert pandas is not None  # the real files never need the fallback
    assert np.array_equal(bits(pandas), bits(expected))


def test_staged_mrclam_table_equals_numpy_on_data_lines():
    path = staged(f"{MRCLAM6}/Robot3_Groundtruth.dat.gz")
    values, lines = _text.numeric_table(path, 4, "a ground-truth row")
    text = _text.read_bytes(path).split(b"\n")
    data = [k for k, line in enumerate(text) if line.strip() and not line.lstrip().startswith(b"#")]
    assert lines.tolist() == [k + 1 for k in data]
    expected = np.fromstring(b"\n".join(text[k] for k in data), sep=" ").reshape(-1, 4)
    assert np.array_equal(bits(values), bits(expected))


# ----------------------------------------------------------------- generated decimals

DIGITS = st.text(alphabet="0123456789", max_size=22)
SPECIAL = st.sampled_from(
    [
        "nan",
        "-nan",
        "inf",
        "-inf",
        "Infinity",
        "1e308",
        "1.7976931348623157e308",
        "1e-320",
        "4.9e-324",
        "2.2250738585072014e-308",
        "-0",
        "-0.0",
        "+0",
        ".5",
        "5.",
        "-.5",
        "+.5",
        "0.1",
        "9007199254740993",
        "9007199254740992",
        "900719925474099.3",
        "0000000000000012.5",
        "1234567890123456",
        "0.000000000000001",
        "999999999999999.9",
        "1e22",
        "1e23",
    ]
)


@st.composite
def decimal(draw) -> str:
    sign = draw(st.sampled_from(["", "", "-", "+"]))
    whole, frac = draw(DIGITS), draw(st.one_of(st.none(), DIGITS))
    if not (whole or frac):
        whole = "0"
    exponent = draw(st.one_of(st.none(), st.none(), st.integers(-330, 330)))
    token = sign + whole + ("" if frac is None else "." + frac)
    return token if exponent is None else token + draw(st.sampled_from("eE")) + str(exponent)


TOKENS = st.lists(st.one_of(decimal(), decimal(), SPECIAL), min_size=1, max_size=40)


@settings(max_examples=300, deadline=None)
@given(tokens=TOKENS, seps=st.lists(st.sampled_from([" ", "\t", " \t ", "  ", "\x0b", "\x0c"]), min_size=1))
def test_numbers_bit_identical_to_python_float(tokens, seps):
    """numbers() on generated decimals (several per line, several separators) equals float() bit for bit."""
    bodies = [seps[k % len(seps)].join(tokens[k : k + 3]) for k in range(0, len(tokens), 3)]
    values, counts = _text.numbers("mem", bodies, np.arange(1, len(bodies) + 1), "a row")
    assert counts.sum() == len(tokens)
    expected = np.array([float(t) for t in tokens])
    nan = np.isnan(expected)
    assert np.array_equal(np.isnan(values), nan)
    assert np.array_equal(bits(values[~nan]), bits(expected[~nan]))


# bytes of the alphabet pandas is given, in any order: signs, dots and exponent letters anywhere
NEAR = st.binary(min_size=1, max_size=12).map(lambda b: bytes(_text._PLAIN[x % len(_text._PLAIN)] for x in b))


def _float_or_none(token: bytes) -> float | None:
    try:
        return float(token)
    except ValueError:
        return None


@settings(max_examples=200, deadline=None)
@given(tokens=st.lists(NEAR, min_size=1, max_size=8))
def test_pandas_accepts_exactly_what_float_accepts(tokens):
    """On its alphabet pandas accepts a text iff float() accepts every token, with float()'s bits."""
    values = _text._pandas_values(b"\n".join(tokens))
    expected = [_float_or_none(t) for t in tokens]
    if any(v is None for v in expected):
        assert values is None, tokens
    else:
        assert values is not None and np.array_equal(bits(values), bits(np.array(expected))), tokens


def test_tokens_at_the_very_start_and_short_texts():
    """Windows of tokens ending within the first 16 bytes are padded, not read from before the text."""
    values, counts = _text.numbers("mem", ["1", "-2.5 3", "12345678901234.5 7"], np.arange(1, 4), "a row")
    assert values.tolist() == [1.0, -2.5, 3.0, 12345678901234.5, 7.0] and counts.tolist() == [1, 2, 2]
    values, counts = _text.numbers("mem", [], np.arange(1, 1), "a row")
    assert values.size == 0 and counts.size == 0


@pytest.mark.parametrize(
    "body, token",
    [
        ("1 2\x013", "2\x013"),
        ("1 1.5.2 3", "1.5.2"),
        ("4 0x10", "0x10"),
        ("1 \xb5", "\xb5"),
        ("- 1", "-"),
        ("1 .", "."),
    ],
)
def test_non_numbers_still_reported_at_their_token(body, token):
    """Control characters are not separators; malformed tokens go to the fallback and fail there."""
    with pytest.raises(DataFormatError) as err:
        _text.numbers("mem", ["0 0", body], np.array([7, 9]), "a row")
    assert err.value.line == 9 and err.value.got == token


def test_form_feed_and_vertical_tab_separate_tokens():
    values, counts = _text.numbers("mem", ["1\x0b2\x0c3\r"], np.array([1]), "a row")
    assert values.tolist() == [1.0, 2.0, 3.0] and counts.tolist() == [3]


@pytest.mark.parametrize("layout", ["header", "interleaved"])
def test_table_of_other_notations_equals_numpy(tmp_path, layout):
    """Exponent notation (as the Plaza files) and long mantissas go to numpy's parser, with or without comment lines between rows."""
    rng = np.random.default_rng(3)
    numbers = rng.normal(scale=1e3, size=(300, 3))
    rows = [" ".join(f"{x:.16e}" if k % 3 else f"{x:.3f}" for k, x in enumerate(r)) for r in numbers]
    if layout == "interleaved":
        rows = [line for r in rows for line in (r, "# comment 1.5")]
    path = tmp_path / "table.txt"
    path.write_text("# header 2.5\n" + "\n".join(rows) + "\n")
    values, lines = _text.numeric_table(path, 3, "a row")
    expected = np.fromstring(" ".join(r for r in rows if not r.startswith("#")), sep=" ").reshape(-1, 3)
    assert np.array_equal(bits(values), bits(expected))
    assert lines[0] == 2 and lines[-1] == (600 if layout == "interleaved" else 301)
