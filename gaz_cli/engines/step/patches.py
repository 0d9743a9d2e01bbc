"""Patches: the box cut into sub-domains, each owning its particles (seed 002's ``patch.cpp``).

The cells of the contact search (side at least a contact's reach, ``nc`` an axis) are grouped
into ``p1 x p2`` patches along axes 1 and 2 (axis 0 is never cut, so that a row of cells
along it lies in one patch and is one range of the arrays). Patch p owns the rows
``slot(p)`` of every particle array, ``base[p] = p * cap`` to ``base[p] + count[p]``, sorted
by cell: the particles of global cell g are the rows ``cstart[g]`` to ``cend[g]``.

Each step, after the drift, the seed's three-step exchange (:func:`_exchange`):

1. each patch marks the particles that left its cells into its send buffer, grouped by the
   patch they go to (one buffer per neighbour: :func:`_mark_leavers`);
2. it compacts its rows, filling the holes from its end (:func:`_compact`);
3. each patch receives from its neighbours' buffers the particles sent to it
   (:func:`_receive`);

then each patch sorts its rows by cell (:func:`_sort_by_cell`). Steps 1-2, 3 and the sort run
one patch a thread (Numba's ``prange`` over the patches: a patch writes only its own rows,
buffers and cells, so the threads need no lock and the result no order; one patch runs
without a parallel region).

Halo: the contact search of a particle reads the cells around it, those of the neighbouring
patches included (their border cells, read in place: threads share memory), so that a
contact across a border is found exactly as inside a patch; in an MPI run every process
holds every particle, halo included, and scans its own patches (:mod:`.ranks`). The order in which
contacts are resolved does not depend on the patches (:mod:`.passes`): the same seed gives
the same rows whatever their number.

Arrays follow the particles (``ident`` the caller's numbering): positions, velocities, pair
accelerations, masses, radii, ages, TC times; :func:`_layout_in` lays the caller's arrays
out, :func:`_layout_out` puts them back in the caller's order.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import prange

from gaz_cli.engines.step.cells import _cell_coord
from gaz_cli.numba_config import njit, pnjit


@njit
def _patch_grid(patches, dim, nc):
    """(p1, p2): patches along axes 1 and 2 for about ``patches`` in all (p1 <= p2, each at most
    nc; 1D: one patch; 2D: all along axis 1)."""
    if dim == 1 or patches <= 1:
        return 1, 1
    if dim == 2:
        return min(patches, nc), 1
    p1 = 1
    for f in range(1, patches + 1):
        if f * f > patches:
            break
        if patches % f == 0:
            p1 = f
    p2 = patches // p1
    return min(p2, nc), min(p1, nc)


@njit
def _patch_cells(p, p1, p2, nc, dim):
    """(lo1, hi1, lo2, hi2): patch p's rows of cells along axes 1 and 2 (all nc along axis 0)."""
    q1 = p % p1
    q2 = p // p1
    lo1 = (q1 * nc + p1 - 1) // p1 if dim > 1 else 0
    hi1 = ((q1 + 1) * nc + p1 - 1) // p1 if dim > 1 else 1
    lo2 = (q2 * nc + p2 - 1) // p2 if dim > 2 else 0
    hi2 = ((q2 + 1) * nc + p2 - 1) // p2 if dim > 2 else 1
    return lo1, hi1, lo2, hi2


@njit
def _patch_of(pos, k, length, nc, p1, p2):
    """The patch owning the cell of row k's centre: (c1 p1 // nc) + p1 (c2 p2 // nc)."""
    dim = pos.shape[1]
    q1 = 0
    q2 = 0
    if dim > 1:
        q1 = _cell_coord(pos[k, 1], length, nc) * p1 // nc
    if dim > 2:
        q2 = _cell_coord(pos[k, 2], length, nc) * p2 // nc
    return q1 + p1 * q2


@njit
def _cell_of(pos, k, length, nc):
    """Global cell number of row k's centre, (c2 nc + c1) nc + c0 (clamped into the box)."""
    dim = pos.shape[1]
    g = 0
    for d in range(dim - 1, -1, -1):
        g = g * nc + _cell_coord(pos[k, d], length, nc)
    return g


@njit
def _pack(pos, vel, acc, mass, radius, age, tlast, k, table, row):
    """Particle k's data into row ``row`` of ``table`` (M, 3 D + 4): position, velocity, pair
    acceleration, mass, radius, age, TC time."""
    dim = pos.shape[1]
    for d in range(dim):
        table[row, d] = pos[k, d]
        table[row, dim + d] = vel[k, d]
        table[row, 2 * dim + d] = acc[k, d]
    table[row, 3 * dim] = mass[k]
    table[row, 3 * dim + 1] = radius[k]
    table[row, 3 * dim + 2] = age[k]
    table[row, 3 * dim + 3] = tlast[k]


@njit
def _unpack(table, row, pos, vel, acc, mass, radius, age, tlast, k):
    """Row ``row`` of ``table`` back into particle k's data (:func:`_pack`)."""
    dim = pos.shape[1]
    for d in range(dim):
        pos[k, d] = table[row, d]
        vel[k, d] = table[row, dim + d]
        acc[k, d] = table[row, 2 * dim + d]
    mass[k] = table[row, 3 * dim]
    radius[k] = table[row, 3 * dim + 1]
    age[k] = table[row, 3 * dim + 2]
    tlast[k] = table[row, 3 * dim + 3]


@numba.njit(inline="always", cache=True, nogil=True, error_model="numpy")
def _copy_row(L, a, S, b):
    """Row a of the layout L into row b of the layout S (L itself, or the other half of its
    double buffer): every particle array, ``ident`` included. Inlined by Numba (a call per
    row, with the reference counts of its 16 arrays, doubled the exchange's time: 0.10 to
    0.21 s on 200 steps of N = 20000)."""
    for d in range(L[0].shape[1]):
        S[0][b, d] = L[0][a, d]
        S[1][b, d] = L[1][a, d]
        S[2][b, d] = L[2][a, d]
    S[3][b] = L[3][a]
    S[4][b] = L[4][a]
    S[5][b] = L[5][a]
    S[6][b] = L[6][a]
    S[7][b] = L[7][a]


@njit
def _layout_in(pos, vel, acc, mass, radius, age, tlast, length, nc, p1, p2, cap, L):
    """Lay the caller's arrays (N rows, its order) out into the patches' rows of the layout L
    (a tuple of the particle arrays, P cap rows; ``count`` (P,) set), each patch sorted by cell
    (:func:`_sort_by_cell`). Returns False when a patch would hold more than cap particles."""
    lpos, lvel, lacc, lmass, lradius, lage, ltlast, ident, count = L[0], L[1], L[2], L[3], L[4], L[5], L[6], L[7], L[8]
    n = pos.shape[0]
    npatch = p1 * p2
    for p in range(npatch):
        count[p] = 0
    for k in range(n):
        p = _patch_of(pos, k, length, nc, p1, p2)
        if count[p] >= cap:
            return False
        row = p * cap + count[p]
        count[p] += 1
        for d in range(pos.shape[1]):
            lpos[row, d] = pos[k, d]
            lvel[row, d] = vel[k, d]
            lacc[row, d] = acc[k, d]
        lmass[row] = mass[k]
        lradius[row] = radius[k]
        lage[row] = age[k]
        ltlast[row] = tlast[k]
        ident[row] = k
    return True


@pnjit
def _layout_out(L, cap, npatch, pos, vel, acc, age, tlast):
    """The layout's particle arrays back into the caller's (ident order)."""
    lpos, lvel, lacc, lage, ltlast, ident, count = L[0], L[1], L[2], L[5], L[6], L[7], L[8]
    if npatch == 1:
        _layout_out_patch(0, cap, lpos, lvel, lacc, lage, ltlast, ident, count, pos, vel, acc, age, tlast)
        return
    for p in prange(npatch):
        _layout_out_patch(p, cap, lpos, lvel, lacc, lage, ltlast, ident, count, pos, vel, acc, age, tlast)


@njit
def _layout_out_patch(p, cap, lpos, lvel, lacc, lage, ltlast, ident, count, pos, vel, acc, age, tlast):
    """Patch p's part of :func:`_layout_out`."""
    for row in range(p * cap, p * cap + count[p]):
        k = ident[row]
        for d in range(pos.shape[1]):
            pos[k, d] = lpos[row, d]
            vel[k, d] = lvel[row, d]
            acc[k, d] = lacc[row, d]
        age[k] = lage[row]
        tlast[k] = ltlast[row]


@njit
def _mark_leavers(L, p, cap, length, nc, p1, p2, sendbuf, sendid, sendcount, dest):
    """Exchange, step 1, for patch p: its particles now in another patch's cells go into its
    send buffer (sendbuf (P cap, 3 D + 4) rows p cap..., :func:`_pack`; sendid their ident),
    grouped by destination (sendcount[p, q] particles for patch q, in row order); their rows
    are marked (dest[row] = q, else -1). Returns the number of leavers."""
    lpos, lvel, lacc, lmass, lradius, lage, ltlast, ident, count = L[0], L[1], L[2], L[3], L[4], L[5], L[6], L[7], L[8]
    npatch = p1 * p2
    base = p * cap
    for q in range(npatch):
        sendcount[p, q] = 0
    leavers = 0
    for row in range(base, base + count[p]):
        q = _patch_of(lpos, row, length, nc, p1, p2)
        if q == p:
            dest[row] = -1
            continue
        dest[row] = q
        sendcount[p, q] += 1
        leavers += 1
    if leavers == 0:
        return 0
    # rows of the buffer: destinations in order, particles in row order (a counting sort)
    fill = np.empty(npatch, np.int64)
    s = base
    for q in range(npatch):
        fill[q] = s
        s += sendcount[p, q]
    for row in range(base, base + count[p]):
        q = dest[row]
        if q < 0:
            continue
        b = fill[q]
        fill[q] += 1
        _pack(lpos, lvel, lacc, lmass, lradius, lage, ltlast, row, sendbuf, b)
        sendid[b] = ident[row]
    return leavers


@njit
def _compact(L, p, cap, dest):
    """Exchange, step 2, for patch p: fill the rows of its leavers (dest >= 0) with the
    particles from the end of its rows (the seed's method: one pass, no shift)."""
    count = L[8]
    base = p * cap
    end = base + count[p]
    row = base
    while row < end:
        if dest[row] < 0:
            row += 1
            continue
        end -= 1  # the last row fills the hole (or is the hole)
        while end > row and dest[end] >= 0:
            end -= 1
        if end > row:
            _copy_row(L, end, L, row)
            dest[row] = -1
        row += 1
    count[p] = end - base


@njit
def _receive(L, q, cap, npatch, sendbuf, sendid, sendcount):
    """Exchange, step 3, for patch q: append the particles its neighbours' buffers hold for it,
    neighbour by neighbour (their order within a patch does not matter: the patch is sorted by
    cell next, and contacts are resolved in an order of their own)."""
    lpos, lvel, lacc, lmass, lradius, lage, ltlast, ident, count = L[0], L[1], L[2], L[3], L[4], L[5], L[6], L[7], L[8]
    for p in range(npatch):
        if sendcount[p, q] == 0:
            continue
        b = p * cap
        for r in range(q):
            b += sendcount[p, r]
        for s in range(b, b + sendcount[p, q]):
            row = q * cap + count[q]
            count[q] += 1
            _unpack(sendbuf, s, lpos, lvel, lacc, lmass, lradius, lage, ltlast, row)
            ident[row] = sendid[s]


@njit
def _sort_by_cell(L, S, p, cap, length, nc, p1, p2, cstart, cend, cellof, xb):
    """Sort patch p's rows by global cell into the other layout S (a counting sort; the caller
    then swaps L and S, which share their ``count``), fill cstart/cend of its cells, and keep
    the positions in xb (the binned positions, from which a particle's moves within the step
    are measured)."""
    lpos, count = L[0], L[8]
    dim = lpos.shape[1]
    base = p * cap
    n = count[p]
    lo1, hi1, lo2, hi2 = _patch_cells(p, p1, p2, nc, dim)
    w1 = hi1 - lo1
    ncl = (hi2 - lo2) * w1 * nc  # the patch's cells, local numbers ((c2 - lo2) w1 + c1 - lo1) nc + c0
    cnt = np.zeros(ncl + 1, np.int64)
    for r in range(n):
        row = base + r
        c0 = _cell_coord(lpos[row, 0], length, nc)
        c1 = _cell_coord(lpos[row, 1], length, nc) if dim > 1 else 0
        c2 = _cell_coord(lpos[row, 2], length, nc) if dim > 2 else 0
        loc = ((c2 - lo2) * w1 + c1 - lo1) * nc + c0
        cellof[row] = loc
        cnt[loc + 1] += 1
    for c in range(ncl):
        cnt[c + 1] += cnt[c]
    for c2 in range(lo2, hi2):
        for c1 in range(lo1, hi1):
            for c0 in range(nc):
                loc = ((c2 - lo2) * w1 + c1 - lo1) * nc + c0
                g = (c2 * nc + c1) * nc + c0 if dim == 3 else (c1 * nc + c0 if dim == 2 else c0)
                cstart[g] = base + cnt[loc]
                cend[g] = base + cnt[loc + 1]
    for r in range(n):
        row = base + r
        dst = base + cnt[cellof[row]]
        cnt[cellof[row]] += 1
        _copy_row(L, row, S, dst)
        for d in range(dim):
            xb[dst, d] = lpos[row, d]


@pnjit
def _exchange(L, S, cap, length, nc, p1, p2, sendbuf, sendid, sendcount, dest, cstart, cend, cellof, xb):
    """The seed's exchange (mark, compact, receive) and the sort by cell into S, one patch a
    thread; the caller then swaps L and S. Returns False, L untouched, when a patch would end
    with more than cap particles (the caller lays the particles out again with more room)."""
    count = L[8]
    npatch = p1 * p2
    if npatch == 1:  # nowhere to go
        _sort_by_cell(L, S, 0, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
        return True
    for p in prange(npatch):
        _mark_leavers(L, p, cap, length, nc, p1, p2, sendbuf, sendid, sendcount, dest)
    for q in range(npatch):
        after = count[q]
        for p in range(npatch):
            after += sendcount[p, q] - sendcount[q, p]
        if after > cap:
            return False
    for p in prange(npatch):
        leavers = 0
        for q in range(npatch):
            leavers += sendcount[p, q]
        if leavers > 0:
            _compact(L, p, cap, dest)
    for q in prange(npatch):
        _receive(L, q, cap, npatch, sendbuf, sendid, sendcount)
    for p in prange(npatch):
        _sort_by_cell(L, S, p, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
    return True


@pnjit
def _sort_all(L, S, cap, length, nc, p1, p2, cstart, cend, cellof, xb):
    """:func:`_sort_by_cell` of every patch into S, one a thread (the caller then swaps L and S)."""
    if p1 * p2 == 1:
        _sort_by_cell(L, S, 0, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
        return
    for p in prange(p1 * p2):
        _sort_by_cell(L, S, p, cap, length, nc, p1, p2, cstart, cend, cellof, xb)
