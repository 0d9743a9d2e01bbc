"""The engine's Numba intrinsics that compute something (gaz_cli.engines.event.intrinsics): the
eight-verdict mask of the float32 rejection pass (_kept8) and the lowest set bit
(_lowest), against numpy on the same values, edge values included."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from gaz_cli.engines.event.intrinsics import _kept8, _lowest


@numba.njit  # (not cached: Numba's cache would not see a change of the intrinsics)
def _masks(arr, row, cols):
    out = np.empty(cols.size, np.int64)
    for k in range(cols.size):
        out[k] = _kept8(arr, row, cols[k])
    return out


@numba.njit
def _lowest_bits(xs):
    out = np.empty(xs.size, np.int64)
    for k in range(xs.size):
        out[k] = _lowest(xs[k])
    return out


@pytest.mark.parametrize("layout", ["rows", "block of a 3D array"])
def test_kept8_marks_each_column_that_is_not_above_zero(layout):
    """Bit i of _kept8(arr, row, c) is set exactly when arr[row, c + i] > 0 is false (<= 0,
    -0.0, NaN: the scalar test the scans made, 'not > 0'), at every column offset c (not
    only multiples of 8), in a row of a C-ordered array or of a block XB[cell]."""
    rng = np.random.default_rng(7)
    special = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 1e-45, -1e-45, 3.0e38],
                       dtype=np.float32)
    values = rng.normal(size=(5, 61)).astype(np.float32)
    values.flat[rng.choice(values.size, 80, replace=False)] = rng.choice(special, 80)
    arr = values
    if layout != "rows":
        blocks = np.full((3, 5, 64), 9.0, dtype=np.float32)
        blocks[1, :, :61] = values
        arr = blocks[1]
    cols = np.arange(0, arr.shape[1] - 8 + 1)
    for row in range(arr.shape[0]):
        got = _masks(arr, row, cols)
        for c, bits in zip(cols, got):
            want = sum(1 << i for i in range(8) if not arr[row, c + i] > 0)
            assert bits == want, (row, c, arr[row, c:c + 8])


def test_lowest_is_the_index_of_the_lowest_set_bit():
    """_lowest(x) for x != 0 (int64, the top bit included) is the index of x's lowest set
    bit: x & -x == 1 << _lowest(x)."""
    rng = np.random.default_rng(8)
    xs = rng.integers(1, 1 << 62, 2000, dtype=np.int64) << rng.integers(0, 2, 2000)
    xs = np.concatenate([xs, np.array([1, 2, 3, 255, 1 << 40, 1 << 62, -(1 << 63), -1],
                                      dtype=np.int64)])
    got = _lowest_bits(xs)
    for x, k in zip(xs.tolist(), got.tolist()):
        assert (x & -x) & ((1 << 64) - 1) == 1 << k, (x, k)


def test_kept8_refuses_a_strided_row():
    """A row whose columns are not adjacent in memory (a strided view) is refused when the
    kernel is compiled: the eight columns are read as one vector."""
    arr = np.zeros((2, 32), dtype=np.float32)[:, ::2]
    with pytest.raises(numba.TypingError):
        _masks(arr, 0, np.arange(4))
