"""Neighbour lists (dense fluids, 2D/3D): radius R_i + R_j + 2h around a centre, rebuilt
when the particle has moved h from it."""

from __future__ import annotations

import math

from gaz_cli.engines.event.intrinsics import _inline, _prefetch
from gaz_cli.engines.event.boundaries import _nearest_near
from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _pair_time_within
from gaz_cli.engines.event.layout import C0, CELL, CNT, DONE, INF, NL_FULL, PR, PT, PV
from gaz_cli.engines.event.neighbours.cells import _block_cell, _move
from gaz_cli.engines.event.prefetch import _prefetch_block, _prefetch_block_rows, _prefetch_listed
from gaz_cli.numba_config import njit

@_inline
def _nl_exit(P, XN, k, h, g, D, GRAV):
    """Absolute time at which particle k (row at its stamp) leaves the sphere of radius h around XN[k].

    Exact root of |d + v t| = h without gravity; with gravity a safe lower
    bound from |d| + |v| t + g t^2 / 2 = h (an early rebuild costs time, never
    correctness).
    """
    d0 = P[k, 0] - XN[k, 0]
    d1 = P[k, 1] - XN[k, 1]
    d2 = P[k, 2] - XN[k, 2] if D > 2 else 0.0
    v0 = P[k, PV]
    v1 = P[k, PV + 1]
    v2 = P[k, PV + 2] if D > 2 else 0.0
    a = v0 * v0 + v1 * v1 + v2 * v2
    dd = d0 * d0 + d1 * d1 + d2 * d2
    if GRAV:
        room = h - math.sqrt(dd)
        if room <= 0.0:
            return P[k, PT]
        sp = math.sqrt(a)
        return P[k, PT] + 2.0 * room / (sp + math.sqrt(a + 2.0 * g * room))
    if a == 0.0:
        return INF
    b = d0 * v0 + d1 * v1 + d2 * v2
    c = dd - h * h
    disc = b * b - a * c
    if disc < 0.0:
        disc = 0.0
    if b <= 0.0:
        t = (-b + math.sqrt(disc)) / a
    else:
        t = -c / (b + math.sqrt(disc))
    if t < 0.0:
        t = 0.0
    return P[k, PT] + t


@_inline
def _scan_nl(P, I, NB, NN, k, t, L, hl, g, best, bj, nc, PP, D, PER, GRAV, PF):
    """Earliest collision of k (its row at time t) with the particles of its neighbour list
    before ``best`` (pass INF, -1 for all): its time, the partner (bj if none is earlier)
    and the partner's event counter I[partner, CNT] (0 if none; read when the partner is
    found, so that the load overlaps the rest of the scan).

    PF (large systems): the neighbours' rows of P and I are all requested from memory
    before the first is read, so that their cache misses overlap.

    Periodic: only a list whose centre's cell (I[k, C0:], of nc an axis) touches a face
    of the box takes nearest images. Inside, every listed pair's centres are within
    R_k + R_m + 2h < L / 3 of each other without wrapping (a cell is at least that wide)
    and each particle within h of its centre, which it left unwrapped (as Smallenburg's
    ``nearboxedge``).
    """
    if PF:
        _prefetch_listed(P, NB, NN, k)
        for s in range(NN[k]):  # and their counters (read when one is the best so far)
            _prefetch(I, NB[k, s])
    wrap = False
    if PER:
        for a in range(D):
            c = I[k, C0 + a]
            if c == 0 or c == nc - 1:
                wrap = True
    xk0 = P[k, 0]
    vk0 = P[k, PV]
    xk1 = P[k, 1]
    vk1 = P[k, PV + 1]
    xk2 = P[k, 2] if D > 2 else 0.0
    vk2 = P[k, PV + 2] if D > 2 else 0.0
    rk = P[k, PR]
    bc = I[bj, CNT] if bj >= 0 else 0
    for s in range(NN[k]):
        m = NB[k, s]
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, xk0, xk1, xk2, vk0, vk1, vk2, g,
                                                    D, GRAV)
        if PER and wrap:
            dx0 = _nearest_near(dx0, L, hl)
            dx1 = _nearest_near(dx1, L, hl)
            if D > 2:
                dx2 = _nearest_near(dx2, L, hl)
        tp = t + _pair_time_within(dx0, dx1, dx2, dv0, dv1, dv2, rk, P[m, PR], PP, D, best - t)
        if tp < best:
            best = tp
            bj = m
            bc = I[m, CNT]
    return best, bj, bc


@_inline
def _gather_nl(P, XN, cells, NN, SCR, k, x0, x1, x2, c0, c1, c2, nc, L, h, D, PER, PF):
    """Neighbours of a list centred at (x0, x1, x2) in cell (c0, c1, c2) into SCR.

    Particle m is a neighbour when |x - XN[m]| < R_k + R_m + 2 h. Returns
    their number, or -1 if SCR or one of their lists would overflow. Needs
    at least 3 cells per axis when periodic (one image per particle).

    Cells are at least 2 R_max + 2 h wide when there are two or more an axis (the
    driver sizes them so), hence R_m <= rcap = (L / nc - 2 h) / 2: a candidate
    farther than R_k + rcap + 2 h is out without reading its row of P (most of
    the 3^D cells' particles are out; their rows would be read for the radius alone).

    Periodic: only a centre whose cell touches a face of the box takes nearest images
    (as the scan, Smallenburg's ``nearboxedge``). Inside, the 3^D cells do not wrap: a
    candidate's centre XN[m] (in its cell, nc >= 3 of width w an axis) is less than 2 w
    from the centre along each axis, and one within reach (R_k + R_m + 2 h <= w) has no
    nearer image, since L / 2 >= 3 w / 2; one whose nearest image differs is more than
    L / 2 >= w away either way, out either way (the same lists as with nearest images).
    """
    capnb = SCR.shape[0]
    hl = 0.5 * L
    rk = P[k, PR]
    rcap = 0.5 * (L / nc - 2.0 * h) if nc > 1 else INF
    far = rk + rcap + 2.0 * h
    far2 = far * far
    cnt = 0
    lo2 = -1 if D > 2 else 0
    hi2 = 1 if D > 2 else 0
    wrap = False
    if PER:
        wrap = c0 == 0 or c0 == nc - 1 or c1 == 0 or c1 == nc - 1
        if D > 2:
            wrap = wrap or c2 == 0 or c2 == nc - 1
    if PF:
        # large systems: the cells, then the rows of their particles, are requested
        # from memory before the test below reads them (a hint: wrapped even with walls)
        _prefetch_block(cells, c0, c1, c2, -1, 1, -1, 1, lo2, hi2, nc, D)
        _prefetch_block_rows(P, XN, NN, cells, c0, c1, c2, lo2, hi2, nc, D)
    for o in range(3 ** D):
        cell, there = _block_cell(c0, c1, c2, o, nc, D, PER)
        if not there:
            continue
        for s in range(1, cells[cell, 0] + 1):
            m = cells[cell, s]
            if m == k:
                continue
            d0 = x0 - XN[m, 0]
            d1 = x1 - XN[m, 1]
            d2 = x2 - XN[m, 2] if D > 2 else 0.0
            if PER and wrap:
                d0 = _nearest_near(d0, L, hl)
                d1 = _nearest_near(d1, L, hl)
                d2 = _nearest_near(d2, L, hl)
            d2s = d0 * d0 + d1 * d1 + d2 * d2
            if d2s >= far2:
                continue
            lim = rk + P[m, PR] + 2.0 * h
            if d2s < lim * lim:
                if cnt >= capnb or NN[m] >= capnb:
                    return -1
                SCR[cnt] = m
                cnt += 1
    return cnt


@njit
def _build_nl(P, XN, I, cells, NB, NN, SCR, nc, L, h, D, periodic):
    """Neighbour lists of every particle around its centre XN (cells already assigned).

    Status NL_FULL if a list would overflow NB's width.
    """
    n = P.shape[0]
    NN[:] = 0
    for k in range(n):
        c2 = I[k, C0 + 2] if D > 2 else 0
        x2 = XN[k, 2] if D > 2 else 0.0
        cnt = _gather_nl(P, XN, cells, NN, SCR, k, XN[k, 0], XN[k, 1], x2,
                         I[k, C0], I[k, C0 + 1], c2, nc, L, h, D, periodic, False)
        if cnt < 0:
            return NL_FULL
        for s in range(cnt):
            NB[k, s] = SCR[s]
        NN[k] = cnt
    return DONE


@_inline
def _recentre(P, XN, I, cells, NB, NN, SCR, k, ng, newcell, nn0, nn1, nn2, D):
    """Re-centre k's neighbour list where k is now (its row at the rebuild time).

    k leaves the lists of its old neighbours, moves to cell newcell = (nn0, nn1, nn2) if
    it changed cell, and joins the lists of the ng new ones gathered in SCR (by
    :func:`_gather_nl`, which checked the room).
    """
    for s in range(NN[k]):
        m = NB[k, s]
        nm = NN[m]
        for u in range(nm):
            if NB[m, u] == k:
                NB[m, u] = NB[m, nm - 1]
                NN[m] = nm - 1
                break
    if newcell != I[k, CELL]:
        _move(cells, I, k, newcell)
        I[k, C0] = nn0
        I[k, C0 + 1] = nn1
        if D > 2:
            I[k, C0 + 2] = nn2
    for a in range(D):
        XN[k, a] = P[k, a]
    for s in range(ng):
        m = SCR[s]
        NB[k, s] = m
        NB[m, NN[m]] = k
        NN[m] += 1
    NN[k] = ng
