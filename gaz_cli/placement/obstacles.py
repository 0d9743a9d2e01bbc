"""Fixed spheres on a grid: for each cell, the spheres a particle anywhere in it could touch.

The small particles of a mixture are placed among the large ones, held fixed
(:mod:`.mixture`): random sequential addition (:mod:`.rsa`) and growth (:mod:`.growth`)
look up here the few large spheres a small particle could meet, instead of scanning the
small particles of cells as wide as a large diameter.

The grid is the placement's own: fine cells of width ``a``, ``nc`` an axis (a point's fine
coordinate ``min(int(x / a), nc - 1)``), grouped ``g`` an axis into the table's cells
(``ncg = ceil(nc / g)`` an axis; ``g`` the smallest keeping the table within
:data:`ENTRIES`). A cell lists each sphere -- each periodic image of it, centre shifted by
whole box lengths -- whose distance to the cell's box is at most its radius plus
``reach`` (the largest radius of the particles placed among them), so a particle of radius
up to ``reach`` anywhere in the cell finds every sphere it could touch, in the frame of the
box its own centre is in.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from gaz_cli.numba_config import njit

ENTRIES = 1 << 21
"""Bound on the table's entries (4 float64 each: 64 MB): a 1:100 mixture in 3D would list
each large sphere in ~10^6 fine cells; the table's cells are then g fine cells wide."""

CELLS = 1 << 22
"""Bound on the table's cells (an int64 head each: 32 MB)."""

Table = namedtuple("Table", ["heads", "spheres", "a", "nc", "g", "ncg"])
"""heads (ncg^D + 1,) int64: the entries of table cell q are spheres[heads[q]:heads[q + 1]];
spheres (M, 4) float64: an image's centre (x, y, z; 0 beyond D) and its radius; the grid:
fine cells of width a, nc an axis, g of them an axis to a table cell, ncg table cells an
axis."""


def table(centres: np.ndarray, radii: np.ndarray, length: float, periodic: bool, reach: float,
          nc: int) -> Table:
    """The table of fixed spheres ``centres`` (K, D) and ``radii`` (K,) for particles of
    radius up to ``reach``, on ``nc`` fine cells an axis of the box [0, length]^D."""
    centres = np.ascontiguousarray(centres, dtype=np.float64)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    k, dim = centres.shape
    a = length / nc
    g = 1
    while g < nc and (_estimate(radii, reach, a * g, dim) > ENTRIES or (-(-nc // g)) ** dim > CELLS):
        g *= 2
    g = min(g, nc)
    ncg = -(-nc // g)
    counts = np.zeros(ncg ** dim + 1, dtype=np.int64)
    spheres = np.zeros((0, 4))
    _fill(centres, radii, float(length), bool(periodic), float(reach), float(a), nc, g, ncg,
          counts, spheres, True)
    heads = np.zeros(ncg ** dim + 1, dtype=np.int64)
    np.cumsum(counts[:-1], out=heads[1:])
    spheres = np.zeros((int(heads[-1]), 4))
    _fill(centres, radii, float(length), bool(periodic), float(reach), float(a), nc, g, ncg,
          heads.copy(), spheres, False)
    return Table(heads, spheres, float(a), int(nc), int(g), int(ncg))


def _estimate(radii, reach, w, dim) -> float:
    """An upper bound on the entries for table cells of width w (every image ignored)."""
    return float(np.sum((np.floor(2.0 * (radii + reach) / w) + 2.0) ** dim))


@njit
def _fill(centres, radii, length, periodic, reach, a, nc, g, ncg, at, spheres, count_only):
    """List every sphere's images in the table cells within its radius plus ``reach``:
    with ``count_only``, count them into at[cell]; else write them at at[cell] (the
    heads, advanced as they fill)."""
    k, dim = centres.shape
    w = g * a
    lo = np.zeros(3, dtype=np.int64)
    hi = np.zeros(3, dtype=np.int64)
    slo = np.zeros(3, dtype=np.int64)
    shi = np.zeros(3, dtype=np.int64)
    y = np.zeros(3)
    for s in range(k):
        rr = (radii[s] + reach) * (1.0 + 1e-9)
        for d in range(3):
            slo[d] = 0
            shi[d] = 0
            if d < dim and periodic:
                # the images whose ball reaches into the box
                slo[d] = -int(math.floor((centres[s, d] + rr) / length))
                shi[d] = -int(math.floor((centres[s, d] - rr) / length))
        for s0 in range(slo[0], shi[0] + 1):
            for s1 in range(slo[1], shi[1] + 1):
                for s2 in range(slo[2], shi[2] + 1):
                    for d in range(3):
                        y[d] = 0.0
                        lo[d] = 0
                        hi[d] = 0
                    for d in range(dim):
                        shift = s0 if d == 0 else (s1 if d == 1 else s2)
                        y[d] = centres[s, d] + shift * length
                        lo[d] = min(max(int(math.floor((y[d] - rr) / w)), 0), ncg - 1)
                        hi[d] = min(max(int(math.floor((y[d] + rr) / w)), 0), ncg - 1)
                    for q0 in range(lo[0], hi[0] + 1):
                        for q1 in range(lo[1], hi[1] + 1):
                            for q2 in range(lo[2], hi[2] + 1):
                                d2 = 0.0
                                for d in range(dim):
                                    q = q0 if d == 0 else (q1 if d == 1 else q2)
                                    b0 = q * w
                                    b1 = min((q + 1) * g, nc) * a
                                    gap = max(b0 - y[d], y[d] - b1, 0.0)
                                    d2 += gap * gap
                                if d2 > rr * rr:
                                    continue
                                cell = q0
                                if dim > 1:
                                    cell = cell * ncg + q1
                                if dim > 2:
                                    cell = cell * ncg + q2
                                if count_only:
                                    at[cell] += 1
                                else:
                                    e = at[cell]
                                    for d in range(3):
                                        spheres[e, d] = y[d]
                                    spheres[e, 3] = radii[s]
                                    at[cell] = e + 1


@njit
def _key(x0, x1, x2, a, nc, g, ncg, dim):
    """The table cell of the point (x0, x1, x2) of the box."""
    cell = min(max(int(x0 / a), 0), nc - 1) // g
    if dim > 1:
        cell = cell * ncg + min(max(int(x1 / a), 0), nc - 1) // g
    if dim > 2:
        cell = cell * ncg + min(max(int(x2 / a), 0), nc - 1) // g
    return cell


@njit
def _touches(heads, spheres, cell, x0, x1, x2, r, dim):
    """Whether a ball of radius r at (x0, x1, x2), in table cell ``cell``, overlaps a sphere
    (beyond 1e-9 relative, as :func:`.overlaps.first_overlap`)."""
    for e in range(heads[cell], heads[cell + 1]):
        d2 = (x0 - spheres[e, 0]) ** 2
        if dim > 1:
            d2 += (x1 - spheres[e, 1]) ** 2
        if dim > 2:
            d2 += (x2 - spheres[e, 2]) ** 2
        s = (r + spheres[e, 3]) * (1.0 - 1e-9)
        if d2 < s * s:
            return True
    return False


@njit
def _touching(heads, spheres, pos, radii, a, nc, g, ncg, out):
    """out[i]: whether ball i of ``pos``/``radii`` overlaps a sphere of the table."""
    n, dim = pos.shape
    for i in range(n):
        x1 = pos[i, 1] if dim > 1 else 0.0
        x2 = pos[i, 2] if dim > 2 else 0.0
        cell = _key(pos[i, 0], x1, x2, a, nc, g, ncg, dim)
        out[i] = _touches(heads, spheres, cell, pos[i, 0], x1, x2, radii[i], dim)


def touching(t: Table, positions: np.ndarray, radii) -> np.ndarray:
    """(N,) bool: which of these balls (centres in the box, radii at most the table's reach)
    overlap a fixed sphere (beyond 1e-9 relative)."""
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    radii = np.broadcast_to(np.asarray(radii, dtype=np.float64), positions.shape[:1]).copy()
    out = np.zeros(positions.shape[0], dtype=np.bool_)
    _touching(t.heads, t.spheres, positions, radii, t.a, t.nc, t.g, t.ncg, out)
    return out
