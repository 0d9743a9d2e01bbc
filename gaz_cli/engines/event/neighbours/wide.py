"""Wide cells for dilute gases without gravity, in a box with walls or periodic: cells several
diameters wide, each scanned by the float32 rejection pass of :mod:`.dilute`.

Cells a diameter wide cost a dilute gas many crossing events per physical event (scene (b)
of benchmarks/engine.py: 8 crossings an event at 28 cells an axis); cells several diameters
wide cost few crossings but many candidates a scan, each an exact float64 pair time. Here
the cells are wide and each holds its particles as a contiguous block of the rows
``XS_ROWS`` of :mod:`.dilute` (``XB[cell, row, slot]``, float32, in the box units of ``XC``,
slot s holding the particle of the cell table's slot s + 1): a scan of a cell is
:func:`.dilute._reject_pass` over its block, vectorised 8 lanes wide (a block's slots
beyond its count, up to a multiple of :data:`.layout.WIDE_LANES`, the pass's vector step,
hold an inert row: x0 = FAR, at rest, radius 0),
then the exact float64 pair time (:func:`.interactions._pair_time`, from the rows) of
the few pairs kept: the exact root decides, as in :mod:`.dilute`. The pairs kept are
found eight verdicts at a time (:func:`.intrinsics._kept8`, a bit mask from one vector
compare, instead of a branch a slot), gathered first (``GB``, and their images' shifts in
``GS``), their rows requested, and timed once every cell is passed over: the rows arrive
meanwhile (measurements: docs/explanation/engine_measurements.md#event-engine-wide-cells).

**Which cells a scan covers: those along the particle's path.** A particle scans at each
of its events (a collision, a wall bounce, a cell crossing, a stale prediction it cannot
replace) and keeps nothing from its earlier scans. Its horizon is its next event of its
own, tx: its next crossing or wall bounce (:func:`.boundaries._crossing`); until then it
stays in its cell on a straight path. A partner that touches it before tx is within the
reach (the two radii, at most the particle's plus the largest) of a point of that path, so
it lies in a cell that meets the path's bounding box widened by the reach
(:func:`_path_block`): the particle's own cell, the one it leaves by, and those whose faces
the path comes within reach of, instead of all 3^D cells around it. A finer choice (the
cells the path is within reach of on every axis at the same time) scans fewer slots but
costs more to work out before each scan than it saves (measurements:
docs/explanation/engine_measurements.md#event-engine-wide-cells). A collision is never
missed: for a pair
that touches at tc, take the later of the two particles' last events before tc, at t*;
that particle's scan at t* covers the cells along its path up to its next event (after
tc), and the other is in the cell it occupies at tc (it has no event in between), within
reach of that path. The predictions later than tx (plus 1e-9 of the time
to it: within the pass's own widening, MARGIN32) are dropped: the particle scans again at
tx, so both predictions of a scan are sure. The round-off bound of the pass is that of
:mod:`.dilute` with that horizon (:func:`.dilute._bounds`): the same units (box edges from
the centre; a particle stays in its cell until its next event), the same positions on the
lines at an epoch moved within REBASE time units (:func:`_rebase`).

The blocks mirror the rows: a particle's slot is rewritten after each event that changes
its row (:func:`_mirror`), all of them at the first predictions (:func:`_mirror_all`); a
crossing moves the cell's last slot into the hole it leaves (:func:`_moved_out`, as
:func:`.cells._move` does in the table). A cell that fills up widens the table and the
blocks (the driver: ``Rows._grow_cells``), slots and units kept.

**A periodic box** (at least 3 cells an axis): a cell across a face of the box is scanned
through its image (:func:`.cells._beside`): the particle is moved by minus the image's shift
(L per axis) for the float32 pass (in box edges, from float64: its coordinate then within
3/2 of the centre, its rounding u 3/4 instead of u/4, inside the slack of the pass's bound 8
+ 2 REBASE V) and for the exact root. With 3 cells an axis or more each of the 3^D cells
around a particle is a different cell, scanned once; a particle wraps at a crossing, an
event of its own, so a pair that touches is within reach of the scanning particle's path
through the image it touches in (:func:`.sizing.use_wide_cells` takes them where they pay;
measurements: docs/explanation/engine_measurements.md#event-engine-wide-cells).

Chosen by :func:`.sizing.use_wide_cells`, its cells per axis by
:func:`.sizing.wide_cells_per_axis`; no gravity, no size classes.
"""

from __future__ import annotations

import numpy as np

from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _earliest_two, _pair_time
from gaz_cli.engines.event.intrinsics import _inline, _kept8, _lowest, _prefetch
from gaz_cli.engines.event.layout import (C0, CELL, INF, KEPT1, KEPT2, NEW, PART, PART2, PCNT, PCNT2, PR,
                                          PV, SLOT, SURE, TCOL, TCOL2, WIDE_LANES)
from gaz_cli.engines.event.neighbours.cells import _beside, _stamp
from gaz_cli.engines.event.neighbours.dilute import (CENTRE, FAR, IL, IT, KEEP, REBASE, RMAX, T0,
                                                     XS_ROWS, _bounds, _choose_units, _mirror_to,
                                                     _reject_pass)

HORIZON_SLACK = 1e-9
"""Predictions up to the horizon plus this fraction of the time to it are kept (far inside
the pass's widening MARGIN32, so every pair that the exact root puts there is kept)."""


def block_width(cap: int) -> int:
    """Slots of a block for a cell table of ``cap`` particles a cell: a multiple of
    WIDE_LANES."""
    return WIDE_LANES * ((cap + WIDE_LANES - 1) // WIDE_LANES)


def empty_blocks(cells: int, cap: int) -> np.ndarray:
    """The blocks of ``cells`` cells of ``cap`` particles, every slot inert."""
    XB = np.zeros((cells, XS_ROWS, block_width(cap)), dtype=np.float32)
    XB[:, 0, :] = FAR
    return XB


def wider_blocks(XB: np.ndarray, cap: int) -> np.ndarray:
    """The blocks ``XB`` widened for ``cap`` particles a cell, their slots kept."""
    new = empty_blocks(XB.shape[0], cap)
    new[:, :, :XB.shape[2]] = XB
    return new


@_inline
def _mirror(P, I, XB, XC, p):
    """Copy particle p's row into its slot of its cell's block."""
    _mirror_to(P, XB[I[p, CELL]], XC, p, I[p, SLOT] - 1)


@_inline
def _mirror_all(P, I, XB, XC, n, t, L):
    """Choose XC's units at time t and copy every row into its slot (the first predictions;
    the other slots stay inert)."""
    _choose_units(P, XC, n, t, L)
    for p in range(n):
        _mirror(P, I, XB, XC, p)


@_inline
def _rebase(P, I, XB, XC, n, t):
    """The epoch moved to t0 = t, every slot rewritten (as :func:`.dilute._rebase`)."""
    XC[T0] = t
    for m in range(n):
        _mirror(P, I, XB, XC, m)


@_inline
def _moved_out(XB, cells, old, sl, co):
    """A particle left slot sl (1-based, as the table's) of cell ``old``, which held co
    particles: the table moved the last one into its slot; so do the blocks, and the last
    slot becomes inert."""
    if sl != co:
        for r in range(XS_ROWS - 1):
            XB[old, r, sl - 1] = XB[old, r, co - 1]
    for r in range(XS_ROWS - 1):
        XB[old, r, co - 1] = 0.0
    XB[old, 0, co - 1] = FAR


@_inline
def _path_block(P, I, XC, edges, p, t, tx, D):
    """The cells around particle p's cell c (p's row at t) where a partner can be when they
    touch before tx, p's next crossing or bounce (p stays in c until then, on its line):
    offsets lo..hi on each axis (-1 or 0, 0 or 1; the third axis 0..0 in 2D), the cells
    that meet the bounding box of p's path from t to tx widened by the reach (p's radius
    plus the largest, :data:`.dilute.RMAX`, with a relative margin far above the round-off
    of the positions). At rest (tx = inf) the whole 3^D block."""
    reach = (P[p, PR] + XC[RMAX] / XC[IL]) * (1.0 + 1e-6)
    lo0, hi0, lo1, hi1, lo2, hi2 = -1, 1, -1, 1, 0, 0
    if D > 2:
        lo2 = -1
        hi2 = 1
    if tx == INF:
        return lo0, hi0, lo1, hi1, lo2, hi2
    dt = tx - t
    for d in range(D):
        c = I[p, C0 + d]
        x = P[p, d]
        e = x + P[p, PV + d] * dt
        lo = -1 if min(x, e) - reach <= edges[c] else 0
        hi = 1 if max(x, e) + reach >= edges[c + 1] else 0
        if d == 0:
            lo0, hi0 = lo, hi
        elif d == 1:
            lo1, hi1 = lo, hi
        else:
            lo2, hi2 = lo, hi
    return lo0, hi0, lo1, hi1, lo2, hi2


@_inline
def _predict_wide(P, I, EV, cells, XB, XC, GB, GS, p, t, tx, n, nc, L, g, lo0, hi0, lo1, hi1,
                  lo2, hi2, PP, D, PER):
    """Particle p's two earliest collisions (its row at t) before tx, in the cells c +
    (lo..hi) on each axis around its cell c (:func:`_path_block`), written to its
    predictions (a full scan: the second is sure). A cell across a periodic face is scanned
    through its image (:func:`.cells._beside`), each of the 3^D cells once. Returns (pair
    times computed exactly, slots the pass went through)."""
    tcut = tx + HORIZON_SLACK * (tx - t)
    if (t - XC[T0]) * XC[IT] > REBASE:
        _rebase(P, I, XB, XC, n, t)
    ok, tau, xk0, xk1, xk2, vk0, vk1, vk2, rk, h2, thr = _bounds(P, XC, p, t, tx)
    best = INF
    bj = -1
    best2 = INF
    bj2 = -1
    oc1 = I[p, PCNT]
    oc2 = I[p, PCNT2]
    src1 = KEPT1
    src2 = KEPT2
    x0 = P[p, 0]
    x1 = P[p, 1]
    x2 = P[p, 2]
    v0 = P[p, 3]
    v1 = P[p, 4]
    v2 = P[p, 5]
    rad = P[p, PR]
    own_cell = I[p, CELL]
    own_slot = I[p, SLOT] - 1
    own = XB[own_cell, 0, own_slot]
    XB[own_cell, 0, own_slot] = FAR  # (p itself out of reach, as in .dilute._keep)
    c0 = I[p, C0]
    c1 = I[p, C0 + 1]
    c2 = I[p, C0 + 2] if D > 2 else 0
    exact = 0
    scanned = 0
    nk = 0  # the pass's survivors gathered in GB (periodic: their image shifts in GS)
    cx0 = (x0 - XC[CENTRE]) * XC[IL]  # p in box edges, float64 (its images: minus 0 or 1)
    cx1 = (x1 - XC[CENTRE]) * XC[IL]
    cx2 = (x2 - XC[CENTRE]) * XC[IL]
    for o0 in range(lo0, hi0 + 1):
        n0, w, inside = _beside(c0 + o0, nc, PER)
        if not inside:
            continue
        s0 = w - 1  # the image's shift, in box edges
        for o1 in range(lo1, hi1 + 1):
            n1, w, inside = _beside(c1 + o1, nc, PER)
            if not inside:
                continue
            s1 = w - 1
            for o2 in range(lo2, hi2 + 1):
                n2, w, inside = _beside(c2 + o2, nc, PER)
                if not inside:
                    continue
                s2 = w - 1
                cell = (n0 * nc + n1) * nc + n2 if D > 2 else n0 * nc + n1
                cnt = cells[cell, 0]
                if cnt == 0:
                    continue
                X = XB[cell]
                kept = True
                if ok:
                    lanes = (cnt + WIDE_LANES - 1) & ~(WIDE_LANES - 1)
                    scanned += lanes
                    if PER:
                        kept = _reject_pass(X, lanes, tau, np.float32(cx0 - s0),
                                            np.float32(cx1 - s1), np.float32(cx2 - s2), vk0,
                                            vk1, vk2, rk, h2, thr, D)
                    else:
                        kept = _reject_pass(X, lanes, tau, xk0, xk1, xk2, vk0, vk1, vk2, rk,
                                            h2, thr, D)
                if not kept:
                    continue
                # the pass's survivors (every slot when it could not filter: not ok),
                # gathered (their rows requested now, they arrive while the other cells
                # are passed over), timed exactly below; eight verdicts at a time
                for g8 in range(0, cnt, 8):
                    bits = (1 << min(8, cnt - g8)) - 1  # (the cell's slots of the eight)
                    if ok:
                        bits &= _kept8(X, KEEP, g8)
                    while bits != 0:
                        s = g8 + _lowest(bits)
                        bits &= bits - 1
                        m = cells[cell, 1 + s]
                        if m == p:
                            continue
                        GB[nk] = m
                        if PER:
                            GS[nk] = (s0 + 1) * 9 + (s1 + 1) * 3 + (s2 + 1)
                        _prefetch(P, m)
                        _prefetch(I, m)
                        nk += 1
    XB[own_cell, 0, own_slot] = own
    for u in range(nk):
        m = GB[u]
        y0, y1, y2 = x0, x1, x2  # p seen from m's image: moved by minus the image's shift
        if PER:
            sh = GS[u]
            y0 = x0 - (sh // 9 - 1) * L
            y1 = x1 - ((sh // 3) % 3 - 1) * L
            y2 = x2 - (sh % 3 - 1) * L
        exact += 1
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, y0, y1, y2, v0, v1, v2, g, D, False)
        tp = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rad, P[m, PR], PP, D)
        if tp < best2 and tp <= tcut:
            best, bj, src1, best2, bj2, src2 = _earliest_two(tp, m, NEW, best, bj, src1, best2,
                                                             bj2, src2)
    EV[p, TCOL] = best
    I[p, PART] = bj
    I[p, PCNT] = _stamp(I, bj, src1, oc1, oc2)
    EV[p, TCOL2] = best2
    I[p, PART2] = bj2
    I[p, SURE] = 1
    I[p, PCNT2] = _stamp(I, bj2, src2, oc1, oc2)
    return exact, scanned
