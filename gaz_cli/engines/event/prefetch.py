"""Memory hints of the event loop: rows and cells requested ahead of use.

Past the caches each event waits on memory, so the loop asks for data ahead of use: the
rows of the next events (the top of the heap) when an event starts, in every run; in
large systems (the driver's PREFETCH_FROM_N) also their cells and partners' rows when it
ends, the next calendar bucket's list one particle an event, a scan's cells and
particles before it reads them. Hints only: the events are the same with or without them
(tested).
"""

from __future__ import annotations

from gaz_cli.engines.event.intrinsics import _inline, _prefetch, _prefetch_at
from gaz_cli.engines.event.layout import C0, I_WIDTH, PART, QN

@_inline
def _wrapped(c, o, nc):
    """Cell coordinate c + o wrapped into 0..nc-1 (o in -1..1)."""
    n = c + o
    return n + nc if n < 0 else (n - nc if n >= nc else n)


@_inline
def _prefetch_block(cells, c0, c1, c2, lo0, hi0, lo1, hi1, lo2, hi2, nc, D):
    """Request the rows of the cells c + (lo..hi) on each axis (wrapped; a hint only)."""
    for o0 in range(lo0, hi0 + 1):
        n0 = _wrapped(c0, o0, nc)
        for o1 in range(lo1, hi1 + 1):
            n1 = _wrapped(c1, o1, nc)
            if D > 2:
                for o2 in range(lo2, hi2 + 1):
                    _prefetch(cells, (n0 * nc + n1) * nc + _wrapped(c2, o2, nc))
            else:
                _prefetch(cells, n0 * nc + n1)


@_inline
def _prefetch_list(NN, NB, m):
    """Request particle m's neighbour list: its count and the first two lines of its row."""
    _prefetch(NN, m)
    _prefetch(NB, m)
    _prefetch_at(NB, m, min(16, NB.shape[1] - 1))


@_inline
def _prefetch_listed(P, NB, NN, k):
    """Request the P rows of the particles on k's neighbour list."""
    for s in range(NN[k]):
        _prefetch(P, NB[k, s])


@_inline
def _prefetch_block_rows(P, XN, NN, cells, c0, c1, c2, lo2, hi2, nc, D):
    """Request the P, XN and NN rows of the particles in the 3^D cells around c (a hint)."""
    for o0 in range(-1, 2):
        n0 = _wrapped(c0, o0, nc)
        for o1 in range(-1, 2):
            n1 = _wrapped(c1, o1, nc)
            for o2 in range(lo2, hi2 + 1):
                if D > 2:
                    cell = (n0 * nc + n1) * nc + _wrapped(c2, o2, nc)
                else:
                    cell = n0 * nc + n1
                for s in range(1, cells[cell, 0] + 1):
                    m = cells[cell, s]
                    _prefetch(XN, m)
                    _prefetch(P, m)
                    _prefetch(NN, m)


@_inline
def _prefetch_next_events(M, P, I, EV, Q, NN, NB, HI, hsize, NL):
    """When an event starts: the next events are near the top of the heap, request their
    rows now; they arrive while this event is processed."""
    for u in range(min(hsize, 3)):
        kn = HI[u]
        _prefetch(M, kn)
        _prefetch(P, kn)
        _prefetch(I, kn)
        _prefetch_at(I, kn, I_WIDTH - 1)  # (a row may straddle two lines)
        _prefetch(EV, kn)
        _prefetch(Q, kn)
        if NL:
            _prefetch_list(NN, NB, kn)


@_inline
def _prefetch_after_event(M, P, I, EV, Q, BH, HI, NN, NB, cells, hsize, cur, nbk, wb, pw, nc,
                          D, CELLS, NL):
    """When an event ends: one step of the walk through the next calendar bucket, then the
    next event's cells and its partner's rows. Returns the walk's (bucket, particle).

    The list of the next bucket is walked one particle an event (each step reads a row
    requested one event before), from when the current bucket went into the heap, so that
    moving it into the heap in turn does not wait on one cache miss after another. The
    next event's particle had its rows requested one event ago; now its cells (CELLS) or
    list (NL) and its partner's rows.
    """
    if wb <= cur:
        wb = cur + 1
        pw = BH[wb & (nbk - 1)]
    elif pw >= 0:
        pw = Q[pw, QN]
    elif wb < cur + 2:
        wb += 1
        pw = BH[wb & (nbk - 1)]
    if pw >= 0:
        _prefetch(Q, pw)
        _prefetch(EV, pw)
    if hsize > 0:
        kn = HI[0]
        if CELLS:
            _prefetch_block(cells, I[kn, C0], I[kn, C0 + 1], I[kn, C0 + 2],
                            -1, 1, -1, 1, -1, 1, nc, D)
        if NL:
            _prefetch_listed(P, NB, NN, kn)
        jn = I[kn, PART]
        if jn >= 0:
            _prefetch(M, jn)
            _prefetch(P, jn)
            _prefetch(I, jn)
            _prefetch_at(I, jn, I_WIDTH - 1)
            _prefetch(Q, jn)
            if NL:
                _prefetch_list(NN, NB, jn)
    return wb, pw
