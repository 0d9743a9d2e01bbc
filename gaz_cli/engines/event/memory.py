"""Memory placement of the engine's arrays: huge pages, and rows in space order.

The event loop reads particle rows at random; past the caches each read waits on memory.
Two things make that wait shorter: arrays on huge pages (fewer TLB misses) and rows
numbered along a Z-order curve of their cells (the 3^D cells around a particle within a
few runs of rows).
"""

from __future__ import annotations

import numpy as np

HUGE_FROM_BYTES = 1 << 18
HUGE_PAGE = 2 << 20
NUMPY_HUGE_MIN = 4 << 20
"""Arrays of HUGE_FROM_BYTES or more are carved out of blocks of at least NUMPY_HUGE_MIN
bytes (numpy asks Linux for transparent huge pages from that size on), starting on a
HUGE_PAGE boundary: random access to them then misses the TLB far less."""


def _alloc(shape, dtype=np.float64, fill=None) -> np.ndarray:
    """A C-contiguous array; large ones on huge pages where the system offers them.

    The event loop reads particle rows at random: on 4 KB pages nearly every
    read of a system of 10^4 particles or more missed the TLB (measurements:
    docs/explanation/engine_measurements.md#event-engine-memory).
    The values are those of np.empty / np.full; only the placement differs.
    """
    dtype = np.dtype(dtype)
    shape = (shape,) if isinstance(shape, (int, np.integer)) else tuple(shape)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize
    if nbytes < HUGE_FROM_BYTES:
        a = np.empty(shape, dtype)
    else:
        raw = np.empty(max(nbytes, NUMPY_HUGE_MIN) + HUGE_PAGE, dtype=np.uint8)
        off = (-raw.ctypes.data) % HUGE_PAGE
        a = raw[off:off + nbytes].view(dtype).reshape(shape)
    if fill is not None:
        a[...] = fill
    return a


def _morton(c: np.ndarray) -> np.ndarray:
    """Z-order keys (N,) int64 of integer cell coordinates c (N, D), each below 2^21."""
    D = c.shape[1]
    key = np.zeros(c.shape[0], dtype=np.int64)
    for d in range(D):
        v = c[:, d].astype(np.int64)
        for b in range(int(v.max()).bit_length() if v.size else 0):
            key |= ((v >> b) & 1) << (b * D + d)
    return key
