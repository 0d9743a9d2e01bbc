"""The cell list of the contact search: cells per axis, a particle's cell, the counting sort.
"""

from __future__ import annotations

import numpy as np

from gaz_cli.numba_config import njit


@njit
def _cell_list(radius, length, dim):
    """(largest radius, cells an axis for its diameter, and the cell list's arrays start,
    cell_of, order, unfilled) for the bodies of ``radius`` (N,) m in a box of side length."""
    n = radius.size
    rmax = 0.0
    for i in range(n):
        if radius[i] > rmax:
            rmax = radius[i]
    nc = _cells_per_axis(length, 2.0 * rmax, n, dim)
    return rmax, nc, np.empty(nc ** dim + 1, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)


@njit
def _cells_per_axis(length, reach, n, dim):
    """Cells per axis: side at least ``reach`` m, at most about 32N cells in all.

    The cap bounds the O(cells) binning cost for dilute gases; 32 cells per
    particle keep piles (settled granular matter, 15 times denser than the
    average) cheap to search.
    """
    nc = int(length / reach) if reach > 0.0 else 1 << 30
    cap = int((32.0 * n + 64.0) ** (1.0 / dim) + 1e-9)
    if nc > cap:
        nc = cap
    if nc < 1:
        nc = 1
    return nc


@njit
def _cell_coord(x, length, nc):
    c = int(x / length * nc)
    if c < 0:
        return 0
    if c >= nc:
        return nc - 1
    return c


@njit
def _bin(pos, length, nc, cell_of, start, order):
    """Counting sort of particles into nc^D cells: particles of cell k are order[start[k]:start[k+1]]."""
    n, dim = pos.shape
    ncells = nc ** dim
    for k in range(ncells + 1):
        start[k] = 0
    for i in range(n):
        k = 0
        for d in range(dim - 1, -1, -1):
            k = k * nc + _cell_coord(pos[i, d], length, nc)
        cell_of[i] = k
        start[k + 1] += 1
    for k in range(ncells):
        start[k + 1] += start[k]
    fill = start[:ncells].copy()
    for i in range(n):
        k = cell_of[i]
        order[fill[k]] = i
        fill[k] += 1
