"""Cell lists (2D/3D): cells at least one diameter wide, a scan covers the 3^D around.

A crossing only scans the 3^(D-1) cells that came into view. A scan runs in two
passes: gather the particles of a block of cells into a buffer, then compute the pair
times of the gathered particles (no branch on a cell's count in either).

The gather copies a cell's slots with unsigned indices (``_U1``...): Numba wraps a
negative signed index around (a compare and a select per index), which it cannot rule
out for a computed one. The scan reads a partner's row by a signed index, and the gather
prefetches no cell rows below the large systems' threshold: neither paid (measurements:
docs/explanation/engine_measurements.md#event-engine-cells).
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.event.intrinsics import _helper, _inline, _prefetch
from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _earliest_two, _pair_time
from gaz_cli.engines.event.layout import (C0, CELL, CELL_FULL, CNT, DONE, GATHER_SLOTS, INF, KEPT1,
                                          KEPT2, NEW, PART, PART2, PCNT, PCNT2, PR, PV, SLOT, SURE,
                                          TCOL, TCOL2)
from gaz_cli.engines.event.memory import _alloc
from gaz_cli.engines.event.prefetch import _prefetch_block
from gaz_cli.numba_config import njit

_U1, _U2, _U3 = np.uint64(1), np.uint64(2), np.uint64(3)


@_inline
def _beside(c, nc, PER):
    """A cell coordinate c next to the box's cells (c in -1..nc): (c wrapped around a
    periodic box, its image w = 0, 1, 2 for a shift of -L, 0, +L, whether there is such a
    cell: with walls none beyond them)."""
    if c < 0:
        return c + nc, 0, PER
    if c >= nc:
        return c - nc, 2, PER
    return c, 1, True


@_inline
def _block_cell(c0, c1, c2, o, nc, D, PER):
    """The o-th cell (o in 0..3^D-1, the last axis fastest) of the 3^D block around cell
    (c0, c1, c2) (2D: c2 unused): (its index, whether there is such a cell: with walls
    none beyond them), wrapped around a periodic box as :func:`_beside` wraps."""
    if D > 2:
        n0, _, in0 = _beside(c0 + o // 9 - 1, nc, PER)
        n1, _, in1 = _beside(c1 + (o // 3) % 3 - 1, nc, PER)
        n2, _, in2 = _beside(c2 + o % 3 - 1, nc, PER)
        return (n0 * nc + n1) * nc + n2, in0 and in1 and in2
    n0, _, in0 = _beside(c0 + o // 3 - 1, nc, PER)
    n1, _, in1 = _beside(c1 + o % 3 - 1, nc, PER)
    return n0 * nc + n1, in0 and in1


@_inline
def _gather_cells(P, I, cells, GB, GS, base, c0, c1, c2, lo0, hi0, lo1, hi1, lo2, hi2, nc,
                  D, PER, IMG, PF):
    """Gather the particles of a block of cells into GB[base:] (pass 1 of a scan); their number.

    The block is c + (lo..hi) on each axis (wrapped when periodic, clipped
    with walls). With IMG, a periodic box of fewer than four cells an axis,
    the image shift of each particle goes into GS, as a code 9 w0 + 3 w1 + w2
    with w = 0, 1, 2 for a shift of -L, 0, +L; with four cells or more, the
    block's image of a particle is the nearest one, taken by the scan. A
    fixed number of slots is copied from every cell and the write position
    moves on by the cell's count, so this pass has no branch that depends on
    how many particles a cell holds (looping cell by cell, particle by
    particle, the branch predictor missed about once a cell: cells hold 0, 1
    or 2 particles at random; measurements:
    docs/explanation/engine_measurements.md#event-engine-cells). PF (large systems): the
    rows of the
    block's cells, then those of the gathered particles, are requested from
    memory before they are read.
    """
    if D < 3:
        lo2 = 0
        hi2 = 0
    if PF:
        _prefetch_block(cells, c0, c1, c2, lo0, hi0, lo1, hi1, lo2, hi2, nc, D)
    # gather (cells hold at least GATHER_SLOTS slots)
    w = base
    for o0 in range(lo0, hi0 + 1):
        n0, w0, in0 = _beside(c0 + o0, nc, PER)
        if not in0:
            continue
        for o1 in range(lo1, hi1 + 1):
            n1, w1, in1 = _beside(c1 + o1, nc, PER)
            if not in1:
                continue
            for o2 in range(lo2, hi2 + 1):
                w2 = 1
                if D > 2:
                    n2, w2, in2 = _beside(c2 + o2, nc, PER)
                    if not in2:
                        continue
                    cell = (n0 * nc + n1) * nc + n2
                else:
                    cell = n0 * nc + n1
                # unsigned indices: no negative-index wraparound (a compare and a
                # select per index) on the copy
                row, at = np.uint64(cell), np.uint64(w)
                cnt = cells[row, 0]
                GB[at] = cells[row, 1]
                GB[at + _U1] = cells[row, 2]
                GB[at + _U2] = cells[row, 3]
                GB[at + _U3] = cells[row, 4]
                if cnt > GATHER_SLOTS:
                    for q in range(GATHER_SLOTS, cnt):
                        GB[w + q] = cells[cell, 1 + q]
                if IMG:
                    code = 9 * w0 + 3 * w1 + w2
                    for q in range(max(cnt, GATHER_SLOTS)):
                        GS[w + q] = code
                w += cnt
    if PF:
        for u in range(base, w):
            _prefetch(P, GB[u])
            _prefetch(I, GB[u])  # the counter of the partner found, read after the scan
    return w - base


@_inline
def _scan_gathered(P, GB, GS, base, ng, k, t, L, g, best, bj, best2, bj2, PP, D, PER, GRAV,
                   IMG):
    """Two earliest collisions of k (its row at time t) with the ng particles gathered at GB[base:].

    Returns the improved (best time, partner, second time, second partner);
    the second saves a rescan when the first turns out stale. With each,
    where it comes from: KEPT1 / KEPT2 (the best / second given in) or NEW
    (found in this scan, to be stamped with the partner's counter now).
    """
    xk0 = P[k, 0]
    vk0 = P[k, PV]
    xk1 = P[k, 1] if D > 1 else 0.0
    vk1 = P[k, PV + 1] if D > 1 else 0.0
    xk2 = P[k, 2] if D > 2 else 0.0
    vk2 = P[k, PV + 2] if D > 2 else 0.0
    rk = P[k, PR]
    src1 = KEPT1
    src2 = KEPT2
    iL = 1.0 / L
    for u in range(base, base + ng):
        m = GB[u]
        # (a periodic box has no gravity: the image shift and the fall never meet)
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, xk0, xk1, xk2, vk0, vk1, vk2, g,
                                                    D, GRAV)
        if IMG:
            code = GS[u]
            dx0 += L * (code // 9 - 1)
            dx1 += L * ((code // 3) % 3 - 1)
            dx2 += L * (code % 3 - 1)
        if PER and not IMG:
            dx0 -= L * np.rint(dx0 * iL)
            if D > 1:
                dx1 -= L * np.rint(dx1 * iL)
            if D > 2:
                dx2 -= L * np.rint(dx2 * iL)
        tp = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rk, P[m, PR], PP, D)
        if tp < best2 and m != k:
            best, bj, src1, best2, bj2, src2 = _earliest_two(tp, m, NEW, best, bj, src1, best2, bj2, src2)
    return best, bj, src1, best2, bj2, src2


# --- kernels that need no specialisation --------------------------------------
@_inline
def _coord(x, a, nc):
    """The cell coordinate, clamped to 0..nc-1, of the coordinate x (m) in cells of side a."""
    return min(max(int(math.floor(x / a)), 0), nc - 1)


@njit
def _assign_cells(P, I, cells, nc, a, D):
    """Put every particle in its cell (cells of side a, nc per axis). Status CELL_FULL if a cell overflows."""
    n = P.shape[0]
    cap = cells.shape[1] - 1
    cells[:, 0] = 0
    for k in range(n):
        cell = 0
        for d in range(D):
            c = _coord(P[k, d], a, nc)
            I[k, C0 + d] = c
            cell = cell * nc + c
        if not _put(I, cells, k, cell, cap):
            return CELL_FULL
    return DONE


@_inline
def _put(I, table, k, cell, cap):
    """Particle k into the next slot of ``table``'s cell (slot 0 holds the count); False if
    the cell is full (capacity cap)."""
    cnt = table[cell, 0] + 1
    if cnt > cap:
        return False
    I[k, CELL] = cell
    I[k, SLOT] = cnt
    table[cell, cnt] = k
    table[cell, 0] = cnt
    return True


def wider(table):
    """A cell table with twice the room of ``table`` (one of its cells was full), its slots kept."""
    from gaz_cli.engines.event import sizing

    new = _alloc((table.shape[0], sizing._cell_width(2 * (table.shape[1] - 1))), np.int32)
    new[:, :table.shape[1]] = table
    return new


@_inline
def _cell_of(P, k, ainv, nc, D):
    """(c0, c1, c2, cell index) of the cell holding particle k's centre (2D/3D; c2 = 0 in 2D)."""
    nn0 = min(max(np.int64(P[k, 0] * ainv), 0), nc - 1)
    nn1 = min(max(np.int64(P[k, 1] * ainv), 0), nc - 1)
    nn2 = 0
    if D > 2:
        nn2 = min(max(np.int64(P[k, 2] * ainv), 0), nc - 1)
        cell = (nn0 * nc + nn1) * nc + nn2
    else:
        cell = nn0 * nc + nn1
    return nn0, nn1, nn2, cell


@_inline
def _move(cells, I, k, new):
    """Particle k out of its cell (the cell's last particle takes its slot) into cell new."""
    old = I[k, CELL]
    sl = I[k, SLOT]
    co = cells[old, 0]
    last = cells[old, co]
    cells[old, sl] = last
    I[last, SLOT] = sl
    cells[old, 0] = co - 1
    cn1 = cells[new, 0] + 1
    I[k, SLOT] = cn1
    cells[new, cn1] = k
    cells[new, 0] = cn1
    I[k, CELL] = new


@_inline
def _stride(d, nc, D):
    """How far apart in the cell index two cells next to each other along axis d are."""
    return 1 if d == D - 1 else (nc if d == D - 2 else nc * nc)


@_inline
def _cell_entered(I, k, code, nc, D):
    """The cell particle k enters at its crossing ``code`` (wrapped around the box)."""
    d = code >> 2
    c = I[k, C0 + d] + (1 if (code & 2) else -1)
    if c < 0:
        c += nc
    elif c >= nc:
        c -= nc
    return I[k, CELL] + (c - I[k, C0 + d]) * _stride(d, nc, D)


@_helper
def _block_entered(d, up):
    """The offsets (lo0, hi0, lo1, hi1, lo2, hi2) of the cells that come into view when a
    particle crosses into the next cell along axis d (up: the one above): the layer beyond."""
    o = 1 if up else -1
    if d == 0:
        return o, o, -1, 1, -1, 1
    if d == 1:
        return -1, 1, o, o, -1, 1
    return -1, 1, -1, 1, o, o


@_inline
def _face_beyond(I, edges, k, d, up, nc, L):
    """Particle k at the face of its cell along axis d (up: the upper one): (its cell
    coordinate c along d, the next one cn, wrapped around a periodic box, the face's
    coordinate xn on the side of cn)."""
    c = I[k, C0 + d]
    if up:
        cn = c + 1
        xn = edges[cn]
        if cn == nc:
            cn = 0
            xn = 0.0
    else:
        cn = c - 1
        xn = edges[c]
        if cn < 0:
            cn = nc - 1
            xn = L
    return c, cn, xn


@_inline
def _cross_face(P, I, cells, edges, k, d, up, nc, L, D):
    """Particle k, at a face of its cell along axis d, moves into the next cell (up: the
    one above), wrapping around a periodic box; its centre is put exactly on the face."""
    c, cn, xn = _face_beyond(I, edges, k, d, up, nc, L)
    P[k, d] = xn
    if cn != c:
        _move(cells, I, k, I[k, CELL] + (cn - c) * _stride(d, nc, D))
        I[k, C0 + d] = cn


@_helper
def _stamp(I, m, src, oc1, oc2):
    """The counter a prediction with partner m keeps: m's now if the scan found it (NEW),
    else that of the kept prediction it comes from (KEPT1: oc1, KEPT2: oc2); 0 if none."""
    if m < 0:
        return 0
    if src == NEW:
        return I[m, CNT]
    return oc1 if src == KEPT1 else oc2


@_inline
def _predict_pairs(P, I, EV, GB, GS, base, ng, p, t, L, g, full, PP, D, PER, GRAV, IMG):
    """Particle p's two earliest collisions among the ng particles gathered at GB[base:],
    written to its predictions.

    A full scan, or (not full) the cells that came into view merged with the two
    predictions kept, which keep the counter they were made with; a new one takes the
    partner's counter now, even when the partner is the same: the kept prediction with
    it may be stale, the new one not. After a full scan the second is sure.
    """
    if full:
        b1 = INF
        p1 = -1
        b2 = INF
        p2 = -1
    else:
        b1 = EV[p, TCOL]
        p1 = I[p, PART]
        b2 = EV[p, TCOL2]
        p2 = I[p, PART2]
    oc1 = I[p, PCNT]
    oc2 = I[p, PCNT2]
    best, bj, src1, best2, bj2, src2 = _scan_gathered(
        P, GB, GS, base, ng, p, t, L, g, b1, p1, b2, p2, PP, D, PER, GRAV, IMG)
    EV[p, TCOL] = best
    I[p, PART] = bj
    I[p, PCNT] = _stamp(I, bj, src1, oc1, oc2)
    EV[p, TCOL2] = best2
    I[p, PART2] = bj2
    if full:
        I[p, SURE] = 1
    I[p, PCNT2] = _stamp(I, bj2, src2, oc1, oc2)
