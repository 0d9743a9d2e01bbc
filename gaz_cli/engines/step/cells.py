"""The cells of the contact search: cells per axis, a particle's cell (the sort by cell is
:func:`.patches._sort_by_cell`).
"""

from __future__ import annotations

from gaz_cli.numba_config import njit


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
