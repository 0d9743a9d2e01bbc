"""Overlap checks on the engine's cells: :func:`first_overlap`, and the cell table and gather
buffers that placement's growth shares (:func:`_cell_table`, :func:`_gather_buffers`)."""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.event.layout import C0, DONE, GATHER_SLOTS, I_WIDTH
from gaz_cli.engines.event.neighbours.cells import _assign_cells, _gather_cells
from gaz_cli.engines.event.sizing import _cell_width
from gaz_cli.placement import mixture
from gaz_cli.numba_config import njit


@njit
def _first_overlap(pos, radii, length, periodic, I, cells, GB, GS, nc):
    """Index of a particle overlapping another (beyond 1e-9 relative), or -1 (2D/3D): each
    particle against the later ones in the 3^D cells around its own (the engine's cells,
    assigned in ``I`` and ``cells``: :func:`_cell_table`; one cell: that cell). O(N)."""
    n, dim = pos.shape
    b = 1 if nc > 1 else 0
    for i in range(n):
        ng = _gather_cells(pos, I, cells, GB, GS, 0, I[i, C0], I[i, C0 + 1],
                           I[i, C0 + 2] if dim > 2 else 0, -b, b, -b, b, -b, b, nc, dim, periodic,
                           False, False)
        for u in range(ng):
            j = GB[u]
            if j > i:
                d2 = 0.0
                for d in range(dim):
                    dx = pos[i, d] - pos[j, d]
                    if periodic:
                        dx -= length * np.rint(dx / length)
                    d2 += dx * dx
                s = (radii[i] + radii[j]) * (1.0 - 1e-9)
                if d2 < s * s:
                    return i
    return -1


def _cell_table(P, I, nc: int, a: float, dim: int) -> np.ndarray:
    """The engine's cell table (:mod:`gaz_cli.engines.event.neighbours.cells`) of the centres P[:, :dim]:
    cells of side a, nc an axis, each particle's cell in I; wide enough for the fullest."""
    cap = GATHER_SLOTS
    while True:
        cells = np.zeros((nc ** dim, _cell_width(cap)), dtype=np.int32)
        if _assign_cells(P, I, cells, nc, a, dim) == DONE:
            return cells
        cap *= 2


def first_overlap(positions: np.ndarray, radii: np.ndarray, length: float,
                  periodic: bool = False) -> int:
    """Index of a particle that overlaps another (beyond 1e-9 relative), or -1; O(N) (1D: the
    rods in line order, O(N log N); sizes far apart: :func:`.mixture.first_overlap`)."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    n, dim = positions.shape
    if n < 2:
        return -1
    if dim == 1:
        # rods that overlap nobody next to them in line order overlap nobody
        order = np.argsort(positions[:, 0], kind="stable")
        x, r = positions[order, 0], radii[order]
        gap = np.diff(x, append=x[0] + length if periodic else np.inf)
        bad = np.flatnonzero(gap < (r + np.roll(r, -1)) * (1.0 - 1e-9))
        return int(order[bad[0]]) if bad.size else -1
    small = mixture.split(dim, radii, length)
    if small is not None:  # sizes far apart: class by class, not on cells sized by the largest
        return mixture.first_overlap(positions, radii, length, periodic, small, first_overlap)
    rmax = float(np.max(radii))
    by_size = int(length / (2.0 * rmax)) if rmax > 0 else n
    nc = max(1, min(by_size, int(math.ceil(n ** (1.0 / dim)))))
    if periodic and nc < 3:
        nc = 1
    I = np.zeros((n, I_WIDTH), dtype=np.int32)
    cells = _cell_table(positions, I, nc, length / nc, dim)
    return int(_first_overlap(positions, radii, float(length), bool(periodic), I, cells,
                              *_gather_buffers(cells, dim), nc))


def _gather_buffers(cells, dim: int) -> tuple:
    """The gather buffers (GB, GS) of a scan of the 3^dim cells of ``cells``' width."""
    room = 3 ** dim * (cells.shape[1] - 1) + GATHER_SLOTS + 1
    return np.empty(room, dtype=np.int32), np.empty(room, dtype=np.int32)
