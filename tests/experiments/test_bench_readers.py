"""The helpers of ``slamarena bench readers`` (the benchmark itself is not part of the test suite):
the bit-mismatch counter and the alternative conversions, which must return the reader's values in
the reader's order, or None where the reader would raise."""

from __future__ import annotations

import numpy as np
import pytest

from slamarena.datasets.formats import _text
from slamarena.experiments.benchmarks import readers


def body_of(text: bytes) -> readers.Body:
    b = np.frombuffer(text, dtype=np.uint8)
    starts, ends, _ = _text._scan(b)
    return readers.Body(text, b, starts, ends, True)


def test_bit_mismatches_counts_every_bit_difference():
    expected = np.array([0.1, -0.0, np.nan, 1.0])
    assert readers.bit_mismatches(expected.copy(), expected) == 0
    assert (
        readers.bit_mismatches(np.array([0.1, 0.0, np.nan, np.nextafter(1.0, 2.0)]), expected) == 2
    )  # -0 vs 0, one ulp
    assert readers.bit_mismatches(None, expected) == 4
    assert readers.bit_mismatches(expected[:3], expected) == 4


@pytest.mark.parametrize("text", [b"1 2.5 -3\n4 5 0.125\n", b"  7 8\n\n9 -0.5 1e3\n10\n"])
def test_alternatives_return_the_readers_values_in_order(text):
    body = body_of(text)
    expected = readers.by_float(body)
    assert np.array_equal(readers.own(body), expected)
    for key, convert in readers.CONVERTERS.items():
        values = convert(body)
        if key == "np.loadtxt" and (body.counts != body.counts[0]).any():
            assert values is None  # one field count for all rows only
        else:
            assert readers.bit_mismatches(values, expected) == 0, key


def test_alternatives_reject_a_non_number():
    body = body_of(b"1 2\n3 x\n")
    for key, convert in readers.CONVERTERS.items():
        assert convert(body) is None, key
