"""How events are ordered: a calendar queue (G. Paul, J. Comput. Phys. 221, 615, 2007).

Buckets of width ``w`` hold unsorted doubly linked lists, the current bucket is a
binary heap, far events wait in an overflow list dealt out again once per turn of the
calendar. O(1) per event on average, independent of N. One entry per particle, keyed
by its earliest prediction EV[k, KEY].

The queue's operations, :func:`_next_bucket` included, are inlined (``_inline``) into
the event loop, where the arrays are borrowed: as separate functions (``_helper``,
which LLVM left as calls) each call paid Numba's reference counting, two indirect calls
(NRT_incref, NRT_decref) per array argument, no-ops on borrowed arrays but calls all the
same (measurements: docs/explanation/engine_measurements.md#event-engine-calendar).
"""

from __future__ import annotations

import numpy as np

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import HEAP, HP, INF, KEY, NONE, OVER, QB, QN, QP
from gaz_cli.numba_config import njit

@_inline
def _sift_up(HK, HI, Q, i, key):
    """Where a key goes at or above heap position i: the parents above it moved down one
    level (their links in Q too); returns the position left free for it."""
    while i > 0:
        p = (i - 1) >> 1
        if HK[p] <= key:
            break
        HK[i] = HK[p]
        HI[i] = HI[p]
        Q[HI[i], HP] = i
        i = p
    return i


@_inline
def _heap_push(HK, HI, Q, hsize, key, k):
    """Particle k into the heap under key; returns the new size."""
    i = _sift_up(HK, HI, Q, hsize, key)
    HK[i] = key
    HI[i] = k
    Q[k, HP] = i
    Q[k, QB] = HEAP
    return hsize + 1


@_inline
def _heap_remove(HK, HI, Q, hsize, i):
    """Remove the heap entry at position i; returns the new size."""
    hsize -= 1
    if i < hsize:
        key = HK[hsize]
        k = HI[hsize]
        at = i
        i = _sift_up(HK, HI, Q, i, key)
        if i == at:
            while True:
                c = 2 * i + 1
                if c >= hsize:
                    break
                if c + 1 < hsize and HK[c + 1] < HK[c]:
                    c += 1
                if HK[c] >= key:
                    break
                HK[i] = HK[c]
                HI[i] = HI[c]
                Q[HI[i], HP] = i
                i = c
        HK[i] = key
        HI[i] = k
        Q[k, HP] = i
    return hsize


@_inline
def _q_insert(Q, HK, HI, BH, k, key, cur, nbk, iw, hsize, ohead):
    """Queue particle k under ``key``; returns (heap size, overflow head)."""
    if key == INF:
        Q[k, QB] = NONE
        return hsize, ohead
    f = key * iw
    if f >= cur + nbk:
        Q[k, QB] = OVER
        Q[k, QP] = -1
        Q[k, QN] = ohead
        if ohead >= 0:
            Q[ohead, QP] = k
        return hsize, k
    b = np.int64(f)
    if b <= cur:
        return _heap_push(HK, HI, Q, hsize, key, k), ohead
    s = b & (nbk - 1)
    h = BH[s]
    Q[k, QB] = s
    Q[k, QP] = -1
    Q[k, QN] = h
    if h >= 0:
        Q[h, QP] = k
    BH[s] = k
    return hsize, ohead


@_inline
def _q_remove(Q, HK, HI, BH, k, nbk, hsize, ohead):
    """Take particle k out of the queue wherever it is; returns (heap size, overflow head)."""
    qb = Q[k, QB]
    if qb == HEAP:
        hsize = _heap_remove(HK, HI, Q, hsize, Q[k, HP])
    elif qb != NONE:
        p = Q[k, QP]
        nx = Q[k, QN]
        if p >= 0:
            Q[p, QN] = nx
        elif qb == OVER:
            ohead = nx
        else:
            BH[qb] = nx
        if nx >= 0:
            Q[nx, QP] = p
    Q[k, QB] = NONE
    return hsize, ohead


@_inline
def _jump(Q, EV, cur, iw, ohead, tstop_b):
    """The bucket to go on from when every bucket is empty: that of the earliest key of the
    overflow list (head ``ohead``), or of the stop tstop_b if sooner, but not before ``cur``;
    the overflow list is dealt out there (see :func:`_next_bucket`), so no event is passed."""
    first = tstop_b
    k = ohead
    while k >= 0:
        first = min(first, EV[k, KEY] * iw)
        k = Q[k, QN]
    first = min(first, 4.0e18)  # (int64; the calendar keeps tstop_b far below, sizing.py)
    if first < cur + 1.0:
        return cur
    return np.int64(first)


@_inline
def _next_bucket(Q, HK, HI, BH, EV, cur, nbk, iw, ohead, tstop_b):
    """Advance the calendar to the next non-empty bucket (not beyond tstop_b, in buckets).

    Moves that bucket's list into the (empty) heap; once per turn of the
    calendar the overflow list is dealt out again. Returns (cur, heap size,
    overflow head, buckets stepped). Called once per bucket (every 3-4 events in a
    dense fluid), inlined all the same: as a call (njit) it paid the reference counting
    of its five arrays and ran slower (measurements:
    docs/explanation/engine_measurements.md#event-engine-calendar).
    """
    mask = nbk - 1
    hsize = 0
    steps = 0
    quiet = 0  # buckets stepped since any could last have been filled
    while hsize == 0:
        if cur + 1 > tstop_b:
            break
        cur += 1
        steps += 1
        quiet += 1
        deal = (cur & mask) == 0
        if deal and quiet >= nbk:
            # a whole turn stepped and no event: every bucket is empty, whatever is queued
            # waits in the overflow list. Jump to the earliest one's bucket (or the stop's)
            # and deal the list out there, instead of stepping one empty bucket at a time: a
            # calendar sized on delays of ~0 (a pair at contact at the start) has buckets of
            # 1e-26 s, and stepping to a stop 1e-11 s away took 1e15 steps, a hang that no
            # signal ended (the loop returns to Python between events only)
            cur = _jump(Q, EV, cur, iw, ohead, tstop_b)
        if deal and ohead >= 0:
            quiet = 0
            k = ohead
            ohead = -1
            while k >= 0:
                nx = Q[k, QN]
                hsize, ohead = _q_insert(Q, HK, HI, BH, k, EV[k, KEY], cur, nbk, iw, hsize, ohead)
                k = nx
        s = cur & mask
        k = BH[s]
        BH[s] = -1
        while k >= 0:
            nx = Q[k, QN]
            hsize = _heap_push(HK, HI, Q, hsize, EV[k, KEY], k)
            k = nx
    return cur, hsize, ohead, steps


@njit
def _build_queue(EV, Q, HK, HI, BH, S):
    """(Re)build the calendar from the keys EV[:, KEY]: current bucket, bucket count and
    width from the loop's state S (a STATE record), where the heap size and overflow head go."""
    st = S[0]
    n = EV.shape[0]
    BH[:] = -1
    cur = st.cur
    nbk = st.nbk
    iw = st.iw
    hsize = 0
    ohead = -1
    for k in range(n):
        hsize, ohead = _q_insert(Q, HK, HI, BH, k, EV[k, KEY], cur, nbk, iw, hsize, ohead)
    st.hsize = hsize
    st.ohead = ohead
