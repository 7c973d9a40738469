"""Matching binary descriptors (ORB's 256-bit rBRIEF) by Hamming distance, with the ratio test and the mutual check.

Descriptors are rows of 32 bytes (n, 32) uint8, viewed as four uint64 words. The distance table ::

    D[i, j] = popcount(a_i XOR b_j)          (n₁, n₂), summed over the four words (np.bitwise_count)

is built in blocks of rows (memory n_block · n₂ · 4 words). A row i keeps its nearest j when

- ratio test (Lowe 2004): D[i, j₁] < ratio · D[i, j₂] for the nearest j₁ and the second nearest j₂;
- mutual check: i is also the nearest row of column j₁ (cross-check);
- D[i, j₁] ≤ max_distance.
"""

from __future__ import annotations

import numpy as np

__all__ = ["hamming_table", "match"]


def _words(d: np.ndarray) -> np.ndarray:
    d = np.ascontiguousarray(d, dtype=np.uint8)
    if d.ndim != 2 or d.shape[1] % 8:
        raise ValueError(f"binary descriptors must be (n, 8k) uint8, got {d.shape}")
    return d.view(np.uint64)


def hamming_table(a: np.ndarray, b: np.ndarray, block: int = 256) -> np.ndarray:
    """D (n₁, n₂) uint16: Hamming distances between the rows of a (n₁, B) and b (n₂, B) uint8."""
    wa, wb = _words(a), _words(b)
    out = np.empty((len(wa), len(wb)), dtype=np.uint16)
    for start in range(0, len(wa), block):
        xor = wa[start : start + block, None, :] ^ wb[None, :, :]
        out[start : start + block] = np.bitwise_count(xor).sum(axis=2, dtype=np.uint16)
    return out


def match(
    a: np.ndarray, b: np.ndarray, ratio: float | None = 0.8, mutual: bool = True, max_distance: int = 256
) -> tuple[np.ndarray, np.ndarray]:
    """Matched index pairs (i (m,), j (m,)) of descriptors a to b (distances from :func:`hamming_table`).

    ``ratio`` None skips the ratio test; a row of ``a`` with fewer than two candidates passes it."""
    if len(a) == 0 or len(b) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    D = hamming_table(a, b)
    rows = np.arange(len(a))
    nearest = np.argmin(D, axis=1)
    best = D[rows, nearest].astype(np.int64)
    keep = best <= max_distance
    if ratio is not None and D.shape[1] >= 2:
        second = np.partition(D, 1, axis=1)[:, 1].astype(np.int64)
        keep &= best < ratio * second
    if mutual:
        keep &= np.argmin(D, axis=0)[nearest] == rows
    return rows[keep], nearest[keep]
