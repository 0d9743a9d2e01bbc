"""Numba kernels of the event-driven engine: plain arrays in, status codes out.

Algorithm (one scheduled event per particle, after Smallenburg, Eur. Phys.
J. E 45, 22, 2022; calendar queue after G. Paul, J. Comput. Phys. 221, 615,
2007):

* Every particle k stores its state at its own time stamp (lazy update) and
  its predictions: its two earliest pair collisions (time, partner, the
  partner's event counter at prediction time) and its next wall bounce,
  cell crossing or neighbour-list rebuild. Its queue key is the earliest,
  an absolute time.
* A collision whose partner has changed course since (counter mismatch) is
  stale: it is never searched for in the queue; when it comes up the second
  prediction takes over if still valid and sure, else the particle looks
  again. The second is sure when it is the second earliest of a full scan,
  or of a full scan merged with the cells a crossing brought into view; once
  it has taken over, the next one is unknown until the particle looks again
  (a partial scan cannot tell it: trusting one cost missed collisions).
  A pair that will collide next is always scheduled by at least one of
  the two, or one of them looks again before.
* Neighbours: in 1D the order never changes, so the previous and next rods.
  In 2D/3D either cell lists with crossing events (cells at least one
  diameter wide, 3^D neighbourhood; a crossing only scans the 3^(D-1) cells
  that came into view) or, for dense fluids, neighbour lists of radius
  R_i + R_j + 2h around a centre, rebuilt when the particle has moved h.
* The queue is a calendar: buckets of width ``w`` hold unsorted doubly
  linked lists, the current bucket is a binary heap, far events wait in an
  overflow list dealt out again once per turn of the calendar. O(1) per
  event on average, independent of N.
* Memory (large systems, IS[S_PF]): past the caches each event waits on
  memory, so the loop asks for data ahead of use: the rows of the next
  events (the top of the heap) when an event starts, their cells and
  partners' rows when it ends, the next calendar bucket's list one particle
  an event, a scan's cells and particles before it reads them, and a
  collision gathers both partners' cells before either scans. With
  neighbour lists: a list's particles before its scan, the next event's list
  when an event ends, and before a rebuild its cells, their particles and the
  lists it edits. Hints only: the events are the same with or without them
  (tested).
* Numerical safety (Bannerman et al., Comput. Part. Mech. 1, 191, 2014): the
  pair time is max(0, c / (-b + sqrt(b^2 - a c))) and only for b < 0, so an
  overlapping pair that approaches collides at once and one that separates
  is left alone; a particle past a wall and moving out bounces at once; a
  wall bounce puts the centre exactly on the wall plane, a crossing exactly
  on the cell face.

Layout: each particle's data sits in one row (``P`` float64 (N, 8): x0 x1 x2
v0 v1 v2 t_stamp radius; ``I`` int32 (N, 13): counter, partner, partner's
counter, crossing code, cell, slot in its cell, cell coordinates c0 c1 c2,
rank in 1D, second partner and its counter, whether that second is sure).
``cells`` int32 (cells, width): the count in column 0, then the particles
(width at least GATHER_SLOTS + 1). The kernels borrow their arrays
(:func:`_borrow`): Numba's atomic reference counting, paid at every helper
taking an array, cost more than the physics. The kernels are specialised
per kind of scene by :func:`build` (dimension, boundary, gravity, radii >
0, neighbour lists, tiny periodic boxes are compile-time constants): a
scene without gravity runs no gravity arithmetic and a scene of points (all
radii 0) does no pair search.

Units are whatever the caller uses (SI in gaz); times are absolute.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.core.extending import intrinsic

from gaz_cli.numba_config import njit

_inline = numba.njit(inline="always", error_model="numpy")
"""Helpers inlined into the kernels at Numba-IR level: the scene flags they
take become constants there (loops over D unrolled, unused branches gone)."""

_helper = numba.njit(error_model="numpy")
"""Helpers without flags, compiled once and left to LLVM to inline: Numba-IR
inlining is slow to compile, and with borrowed arrays a call costs nothing
much."""

INF = math.inf

# --- row layouts ------------------------------------------------------------
# P (N, 8) float64
PV = 3  # velocity columns 3..5 (positions 0..2)
PT = 6  # time stamp of the row
PR = 7  # radius
P_WIDTH = 8
# I (N, 12) int32
CNT, PART, PCNT, CODE, CELL, SLOT, C0, RANK, PART2, PCNT2, SURE = 0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12
I_WIDTH = 13
# EV (N, 4) float64: predictions (first and second collision, crossing, queue key)
TCOL, TX, KEY, TCOL2 = 0, 1, 2, 3
EV_WIDTH = 4
# Q (N, 4) int32: queue links. QB: bucket slot (>= 0), or HEAP / OVER / NONE
QB, QN, QP, HP = 0, 1, 2, 3
HEAP, OVER, NONE = -1, -2, -3

# IS int64 state vector
(S_CUR, S_HSIZE, S_OHEAD, S_NBK, S_EVENTS, S_COLL, S_BOUNCE, S_CROSS, S_STALE,
 S_NBB, S_NCB, S_BUFCAP, S_RECB, S_RECC, S_NC, S_REBUILD, S_STEPS, S_N, S_SECOND, S_PF,
 S_OVERLAP, S_PAIRS) = range(22)
IS_SIZE = 22
# FS float64 state vector
F_W, F_IW, F_VIRIAL, F_L, F_G, F_E, F_TC, F_H, F_TNOW = range(9)
FS_SIZE = 9

OVERLAP_TOL = 1.0 - 1e-9
"""A colliding pair closer than sqrt(OVERLAP_TOL) (R_i + R_j) counts as found overlapping."""

KEPT1, KEPT2, NEW = 1, 2, 0
"""Where a cell scan's result comes from: the first or second prediction given in, or the scan."""

GATHER_SLOTS = 4
"""Slots copied from every cell, whatever its count, when a scan gathers particles
(the count is rarely above it; the rest are copied one by one)."""

NLCODE = 1 << 10
"""Crossing code of a neighbour-list rebuild (leaving the sphere of radius h)."""

# kernel status codes
DONE, BUFFER_FULL, CELL_FULL, PAUSE, NL_FULL = 0, 1, 2, 3, 4


# --- small helpers ----------------------------------------------------------
@intrinsic
def _borrow(typingctx, arr):
    """The same array without its reference count (a borrowed view).

    Numba increments and decrements an array's reference count, atomically,
    wherever an array variable is copied, which includes every inlined helper
    taking the array; in the event loop that cost more than the physics. A
    kernel borrows its arguments once at entry: the caller holds the real
    references for the whole call, so the views stay valid, and NRT_incref
    on a null meminfo is a no-op that LLVM removes.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, value=args[0])
        dst = context.make_array(sig.return_type)(context, builder)
        for name in ("parent", "nitems", "itemsize", "data", "shape", "strides"):
            setattr(dst, name, getattr(src, name))
        dst.meminfo = context.get_constant_null(types.MemInfoPointer(types.voidptr))
        return dst._getvalue()

    return arr(arr), codegen


def _emit_prefetch(context, builder, aryty, arr, idxs):
    """Emit llvm.prefetch (read, keep in all cache levels, data cache) of element idxs of arr."""
    ary = context.make_array(aryty)(context, builder, value=arr)
    ptr = cgutils.get_item_pointer2(context, builder, ary.data,
                                    cgutils.unpack_tuple(builder, ary.shape),
                                    cgutils.unpack_tuple(builder, ary.strides), aryty.layout,
                                    idxs, wraparound=False)
    i32 = ir.IntType(32)
    if getattr(ptr.type, "is_opaque", False):  # LLVM with opaque pointers
        name = "llvm.prefetch.p0"
    else:
        ptr = builder.bitcast(ptr, ir.IntType(8).as_pointer())
        name = "llvm.prefetch.p0i8"
    fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
    fn = cgutils.get_or_insert_function(builder.module, fnty, name)
    builder.call(fn, [ptr, i32(0), i32(3), i32(1)])


@intrinsic
def _prefetch(typingctx, arr, i):
    """Ask the CPU to start loading row i of an array into the cache (llvm.prefetch).

    A hint with no effect on results: on large systems the rows of the 3^D
    cells of a scan are all requested at once instead of one after the
    other, so their cache misses overlap.
    """
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        zero = context.get_constant(types.intp, 0)
        _emit_prefetch(context, builder, sig.args[0], args[0],
                       [idx, zero] if sig.args[0].ndim == 2 else [idx])
        return context.get_dummy_value()

    return types.void(arr, i), codegen


@intrinsic
def _prefetch_at(typingctx, arr, i, j):
    """Ask the CPU to start loading element (i, j) of a 2D array into the cache (a hint)."""
    if not isinstance(arr, types.Array) or arr.ndim != 2 or not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        col = context.cast(builder, args[2], sig.args[2], types.intp)
        _emit_prefetch(context, builder, sig.args[0], args[0], [idx, col])
        return context.get_dummy_value()

    return types.void(arr, i, j), codegen


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


@intrinsic
def _fma(typingctx, x, y, z):
    """x * y + z rounded once (LLVM's llvm.fma.f64: the FMA instruction where the CPU has one,
    a correctly rounded library call where it does not)."""
    if not all(isinstance(a, types.Float) for a in (x, y, z)):
        return None

    def codegen(context, builder, sig, args):
        f64 = ir.DoubleType()
        vals = [context.cast(builder, v, t, types.float64) for v, t in zip(args, sig.args)]
        fn = builder.module.declare_intrinsic("llvm.fma", [f64], ir.FunctionType(f64, [f64] * 3))
        return builder.call(fn, vals)

    return types.float64(types.float64, types.float64, types.float64), codegen


@_inline
def _cross(a, b, c, d):
    """a d - b c without cancellation (Kahan's algorithm with a fused multiply-add): within
    two roundings of the exact value however close a d and b c are."""
    w = b * c
    return _fma(a, d, -w) - _fma(b, c, -w)


@_inline
def _pair_dt(dx0, dx1, dx2, dv0, dv1, dv2, sig, D):
    """Time until |dx + dv t| = sig: max(0, c / (-b + sqrt(b^2 - a c))) if b < 0 and b^2 > a c, else inf.

    The stable root of physics.md section 9: an overlapping pair that
    approaches collides at once (0), one that separates never (inf).
    The discriminant is computed as a sig^2 - |dx x dv|^2 (Lagrange's
    identity), not b^2 - a c: for a grazing pair seen from afar b^2 and a c
    are both ~ a |dx|^2 and their difference loses 1e-16 (|dx|/sig)^2 of
    itself, enough to turn a hit into a miss at 1000 sigma; the components
    of the cross product, each a difference of two products, are computed
    by :func:`_cross` without cancellation, so the discriminant is right to
    a few 1e-16 of a sig^2 at any distance. Written without branches: in a
    scan the sign of b is a coin toss that a branch predictor loses half
    the time.
    """
    b = dx0 * dv0
    c = dx0 * dx0
    a = dv0 * dv0
    cross = 0.0
    if D > 1:
        b += dx1 * dv1
        c += dx1 * dx1
        a += dv1 * dv1
        cz = _cross(dx0, dx1, dv0, dv1)
        cross = cz * cz
    if D > 2:
        b += dx2 * dv2
        c += dx2 * dx2
        a += dv2 * dv2
        cx = _cross(dx1, dx2, dv1, dv2)
        cy = _cross(dx2, dx0, dv2, dv0)
        cross += cx * cx + cy * cy
    c -= sig * sig
    disc = a * (sig * sig) - cross
    t = c / (math.sqrt(max(disc, 0.0)) - b)
    t = max(t, 0.0)
    return t if (b < 0.0 and disc > 0.0) else INF


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
    or 2 particles at random; measured on the standard scene, gathering first
    runs 14% more collisions a second). PF (large systems): the rows of the
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
        n0 = c0 + o0
        w0 = 1
        if n0 < 0:
            if PER:
                n0 += nc
                w0 = 0
            else:
                continue
        elif n0 >= nc:
            if PER:
                n0 -= nc
                w0 = 2
            else:
                continue
        for o1 in range(lo1, hi1 + 1):
            n1 = c1 + o1
            w1 = 1
            if n1 < 0:
                if PER:
                    n1 += nc
                    w1 = 0
                else:
                    continue
            elif n1 >= nc:
                if PER:
                    n1 -= nc
                    w1 = 2
                else:
                    continue
            for o2 in range(lo2, hi2 + 1):
                w2 = 1
                if D > 2:
                    n2 = c2 + o2
                    if n2 < 0:
                        if PER:
                            n2 += nc
                            w2 = 0
                        else:
                            continue
                    elif n2 >= nc:
                        if PER:
                            n2 -= nc
                            w2 = 2
                        else:
                            continue
                    cell = (n0 * nc + n1) * nc + n2
                else:
                    cell = n0 * nc + n1
                cnt = cells[cell, 0]
                GB[w] = cells[cell, 1]
                GB[w + 1] = cells[cell, 2]
                GB[w + 2] = cells[cell, 3]
                GB[w + 3] = cells[cell, 4]
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
def _scan_gathered(P, GB, GS, base, ng, k, t, L, g, best, bj, best2, bj2, D, PER, GRAV, IMG):
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
        dtm = t - P[m, PT]
        dx0 = P[m, 0] + P[m, PV] * dtm - xk0
        dv0 = P[m, PV] - vk0
        dx1 = 0.0
        dv1 = 0.0
        dx2 = 0.0
        dv2 = 0.0
        if D > 1:
            dx1 = P[m, 1] + P[m, PV + 1] * dtm - xk1
            dv1 = P[m, PV + 1] - vk1
        if D > 2:
            dx2 = P[m, 2] + P[m, PV + 2] * dtm - xk2
            dv2 = P[m, PV + 2] - vk2
        if IMG:
            code = GS[u]
            dx0 += L * (code // 9 - 1)
            dx1 += L * ((code // 3) % 3 - 1)
            dx2 += L * (code % 3 - 1)
        if GRAV:
            if D == 3:
                dx2 -= 0.5 * g * dtm * dtm
                dv2 -= g * dtm
            else:
                dx1 -= 0.5 * g * dtm * dtm
                dv1 -= g * dtm
        if PER and not IMG:
            dx0 -= L * np.rint(dx0 * iL)
            if D > 1:
                dx1 -= L * np.rint(dx1 * iL)
            if D > 2:
                dx2 -= L * np.rint(dx2 * iL)
        tp = t + _pair_dt(dx0, dx1, dx2, dv0, dv1, dv2, rk + P[m, PR], D)
        if tp < best2 and m != k:
            if tp < best:
                best2 = best
                bj2 = bj
                src2 = src1
                best = tp
                bj = m
                src1 = NEW
            else:
                best2 = tp
                bj2 = m
                src2 = NEW
    return best, bj, src1, best2, bj2, src2


@_inline
def _scan_1d(P, order, k, rank, n, t, L, g, PER, GRAV):
    """Earliest collision of rod k (its row at time t) with its two neighbours in line order."""
    best = INF
    bj = -1
    xk = P[k, 0]
    vk = P[k, PV]
    for side in range(-1, 2, 2):
        r2 = rank + side
        sh = 0.0
        if r2 < 0:
            if PER:
                r2 += n
                sh = -L
            else:
                continue
        elif r2 >= n:
            if PER:
                r2 -= n
                sh = L
            else:
                continue
        m = order[r2]
        if m == k:
            continue
        dtm = t - P[m, PT]
        dx = P[m, 0] + P[m, PV] * dtm + sh - xk
        dv = P[m, PV] - vk
        if GRAV:
            dx -= 0.5 * g * dtm * dtm
            dv -= g * dtm
        tp = t + _pair_dt(dx, 0.0, 0.0, dv, 0.0, 0.0, P[k, PR] + P[m, PR], 1)
        if tp < best:
            best = tp
            bj = m
    return best, bj


@_inline
def _crossing(P, I, edges, k, nc, n, L, g, D, PER, GRAV, PAIRS, NL):
    """(absolute time, code) of particle k's next wall bounce or cell crossing.

    code = 4 d + 2 [towards +] + [a wall]; (inf, -1) if there is none.
    Along the gravity axis the times come from the stable quadratic forms
    of physics.md section 10. With neighbour lists (NL) there are no cell
    crossings: only the walls.
    """
    best = INF
    code = -1
    if PER and (D == 1 or not PAIRS or NL):
        return best, code
    r = P[k, PR]
    for d in range(D):
        x = P[k, d]
        v = P[k, PV + d]
        has_lo = True
        has_hi = True
        if D == 1:
            if PAIRS:
                rk = I[k, RANK]
                has_lo = rk == 0
                has_hi = rk == n - 1
            lo = r
            hi = L - r
            lo_wall = True
            hi_wall = True
        elif NL:
            lo = r
            hi = L - r
            lo_wall = True
            hi_wall = True
        else:
            c = I[k, C0 + d]
            if PER:
                lo = edges[c]
                hi = edges[c + 1]
                lo_wall = False
                hi_wall = False
            else:
                lo_wall = c == 0
                hi_wall = c == nc - 1
                lo = r if lo_wall else edges[c]
                hi = L - r if hi_wall else edges[c + 1]
        dt = INF
        up = False
        wall = False
        if GRAV and d == D - 1:
            if v > 0.0 and has_hi:
                du = v * v - 2.0 * g * (hi - x)
                if du >= 0.0:
                    dt = 2.0 * (hi - x) / (v + math.sqrt(du))
                    up = True
                    wall = hi_wall
            if not up and has_lo:
                dd = v * v + 2.0 * g * (x - lo)
                if dd < 0.0:
                    dd = 0.0
                if v >= 0.0:
                    dt = (v + math.sqrt(dd)) / g
                else:
                    dt = 2.0 * (x - lo) / (math.sqrt(dd) - v)
                wall = lo_wall
        else:
            if v > 0.0 and has_hi:
                dt = (hi - x) / v
                up = True
                wall = hi_wall
            elif v < 0.0 and has_lo:
                dt = (lo - x) / v
                wall = lo_wall
        if dt < 0.0:
            dt = 0.0
        if dt < best:
            best = dt
            code = 4 * d + (2 if up else 0) + (1 if wall else 0)
    return P[k, PT] + best, code


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
def _scan_nl(P, NB, NN, k, t, L, hl, g, best, bj, D, PER, GRAV, PF):
    """Earliest collision of k (its row at time t) with the particles of its neighbour list.

    PF (large systems): the neighbours' rows are all requested from memory
    before the first is read, so that their cache misses overlap.
    """
    if PF:
        _prefetch_listed(P, NB, NN, k)
    xk0 = P[k, 0]
    vk0 = P[k, PV]
    xk1 = P[k, 1]
    vk1 = P[k, PV + 1]
    xk2 = P[k, 2] if D > 2 else 0.0
    vk2 = P[k, PV + 2] if D > 2 else 0.0
    rk = P[k, PR]
    for s in range(NN[k]):
        m = NB[k, s]
        dtm = t - P[m, PT]
        dx0 = P[m, 0] + P[m, PV] * dtm - xk0
        dv0 = P[m, PV] - vk0
        dx1 = P[m, 1] + P[m, PV + 1] * dtm - xk1
        dv1 = P[m, PV + 1] - vk1
        dx2 = 0.0
        dv2 = 0.0
        if D > 2:
            dx2 = P[m, 2] + P[m, PV + 2] * dtm - xk2
            dv2 = P[m, PV + 2] - vk2
        if GRAV:
            if D == 3:
                dx2 -= 0.5 * g * dtm * dtm
                dv2 -= g * dtm
            else:
                dx1 -= 0.5 * g * dtm * dtm
                dv1 -= g * dtm
        if PER:
            if dx0 > hl:
                dx0 -= L
            elif dx0 < -hl:
                dx0 += L
            if dx1 > hl:
                dx1 -= L
            elif dx1 < -hl:
                dx1 += L
            if D > 2:
                if dx2 > hl:
                    dx2 -= L
                elif dx2 < -hl:
                    dx2 += L
        tp = t + _pair_dt(dx0, dx1, dx2, dv0, dv1, dv2, rk + P[m, PR], D)
        if tp < best:
            best = tp
            bj = m
    return best, bj


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
def _gather_nl(P, XN, cells, NN, SCR, k, x0, x1, x2, c0, c1, c2, nc, L, h, D, PER, PF):
    """Neighbours of a list centred at (x0, x1, x2) in cell (c0, c1, c2) into SCR.

    Particle m is a neighbour when |x - XN[m]| < R_k + R_m + 2 h. Returns
    their number, or -1 if SCR or one of their lists would overflow. Needs
    at least 3 cells per axis when periodic (one image per particle).
    """
    capnb = SCR.shape[0]
    hl = 0.5 * L
    rk = P[k, PR]
    cnt = 0
    lo2 = -1 if D > 2 else 0
    hi2 = 1 if D > 2 else 0
    if PF:
        # large systems: the cells, then the rows of their particles, are requested
        # from memory before the test below reads them (a hint: wrapped even with walls)
        _prefetch_block(cells, c0, c1, c2, -1, 1, -1, 1, lo2, hi2, nc, D)
        _prefetch_block_rows(P, XN, NN, cells, c0, c1, c2, lo2, hi2, nc, D)
    for o0 in range(-1, 2):
        n0 = c0 + o0
        if n0 < 0 or n0 >= nc:
            if PER:
                n0 = n0 + nc if n0 < 0 else n0 - nc
            else:
                continue
        for o1 in range(-1, 2):
            n1 = c1 + o1
            if n1 < 0 or n1 >= nc:
                if PER:
                    n1 = n1 + nc if n1 < 0 else n1 - nc
                else:
                    continue
            for o2 in range(lo2, hi2 + 1):
                if D > 2:
                    n2 = c2 + o2
                    if n2 < 0 or n2 >= nc:
                        if PER:
                            n2 = n2 + nc if n2 < 0 else n2 - nc
                        else:
                            continue
                    cell = (n0 * nc + n1) * nc + n2
                else:
                    cell = n0 * nc + n1
                for s in range(1, cells[cell, 0] + 1):
                    m = cells[cell, s]
                    if m == k:
                        continue
                    d0 = x0 - XN[m, 0]
                    d1 = x1 - XN[m, 1]
                    d2 = x2 - XN[m, 2] if D > 2 else 0.0
                    if PER:
                        if d0 > hl:
                            d0 -= L
                        elif d0 < -hl:
                            d0 += L
                        if d1 > hl:
                            d1 -= L
                        elif d1 < -hl:
                            d1 += L
                        if d2 > hl:
                            d2 -= L
                        elif d2 < -hl:
                            d2 += L
                    lim = rk + P[m, PR] + 2.0 * h
                    if d0 * d0 + d1 * d1 + d2 * d2 < lim * lim:
                        if cnt >= capnb or NN[m] >= capnb:
                            return -1
                        SCR[cnt] = m
                        cnt += 1
    return cnt


# --- calendar queue -----------------------------------------------------------
@_helper
def _heap_push(HK, HI, Q, hsize, key, k):
    i = hsize
    while i > 0:
        p = (i - 1) >> 1
        if HK[p] <= key:
            break
        HK[i] = HK[p]
        HI[i] = HI[p]
        Q[HI[i], HP] = i
        i = p
    HK[i] = key
    HI[i] = k
    Q[k, HP] = i
    Q[k, QB] = HEAP
    return hsize + 1


@_helper
def _heap_remove(HK, HI, Q, hsize, i):
    """Remove the heap entry at position i; returns the new size."""
    hsize -= 1
    if i < hsize:
        key = HK[hsize]
        k = HI[hsize]
        moved = False
        while i > 0:
            p = (i - 1) >> 1
            if HK[p] <= key:
                break
            HK[i] = HK[p]
            HI[i] = HI[p]
            Q[HI[i], HP] = i
            i = p
            moved = True
        if not moved:
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


@_helper
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


@_helper
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


@njit
def _next_bucket(Q, HK, HI, BH, EV, cur, nbk, iw, ohead, tstop_b):
    """Advance the calendar to the next non-empty bucket (not beyond tstop_b, in buckets).

    Moves that bucket's list into the (empty) heap; once per turn of the
    calendar the overflow list is dealt out again. Returns (cur, heap size,
    overflow head, buckets stepped). Called once per bucket, so not inlined.
    """
    mask = nbk - 1
    hsize = 0
    steps = 0
    while hsize == 0:
        if cur + 1 > tstop_b:
            break
        cur += 1
        steps += 1
        if (cur & mask) == 0 and ohead >= 0:
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


# --- kernels that need no specialisation --------------------------------------
@njit
def _assign_cells(P, I, cells, nc, a, D):
    """Put every particle in its cell (cells of side a, nc per axis). Status CELL_FULL if a cell overflows."""
    n = P.shape[0]
    cap = cells.shape[1] - 1
    cells[:, 0] = 0
    for k in range(n):
        cell = 0
        for d in range(D):
            c = int(math.floor(P[k, d] / a))
            if c < 0:
                c = 0
            elif c >= nc:
                c = nc - 1
            I[k, C0 + d] = c
            cell = cell * nc + c
        cnt = cells[cell, 0] + 1
        if cnt > cap:
            return CELL_FULL
        I[k, CELL] = cell
        I[k, SLOT] = cnt
        cells[cell, cnt] = k
        cells[cell, 0] = cnt
    return DONE


@njit
def _build_queue(EV, Q, HK, HI, BH, IS, FS):
    """(Re)build the calendar from the keys EV[:, KEY], current bucket IS[S_CUR]."""
    n = EV.shape[0]
    BH[:] = -1
    cur = IS[S_CUR]
    nbk = IS[S_NBK]
    iw = FS[F_IW]
    hsize = 0
    ohead = -1
    for k in range(n):
        hsize, ohead = _q_insert(Q, HK, HI, BH, k, EV[k, KEY], cur, nbk, iw, hsize, ohead)
    IS[S_HSIZE] = hsize
    IS[S_OHEAD] = ohead


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


@njit
def _state_at(P, t, g, D, out_x, out_v):
    """Positions and velocities of every particle at time t (no change to the rows)."""
    n = P.shape[0]
    for k in range(n):
        dt = t - P[k, PT]
        for d in range(D):
            out_x[k, d] = P[k, d] + P[k, PV + d] * dt
            out_v[k, d] = P[k, PV + d]
        if g != 0.0:
            out_x[k, D - 1] -= 0.5 * g * dt * dt
            out_v[k, D - 1] -= g * dt


# --- specialised kernels --------------------------------------------------------
@functools.lru_cache(maxsize=None)
def build(D: int, PER: bool, GRAV: bool, PAIRS: bool, NL: bool, IMG: bool = False):
    """The kernels for one kind of scene; the flags are compile-time constants.

    D dimension; PER periodic box (else hard walls); GRAV uniform gravity
    along axis D-1; PAIRS some radius > 0; NL neighbour lists (2D/3D,
    PAIRS) instead of cell-crossing events; IMG a periodic box of fewer than
    four cells an axis (cell scans carry each cell's image shift instead of
    taking the nearest image). The restitution is a run-time
    value: its branch sits in the collision rule, off the search paths.
    Returns a namespace holding ``loop``.
    """
    NL = bool(NL and PAIRS and D > 1)
    IMG = bool(IMG and PER and PAIRS and D > 1 and not NL)

    @njit
    def loop(P, M, TL, XN, I, EV, Q, HK, HI, BH, cells, GB, GS, NB, NN, SCR, order, edges,
             ID, IS, FS, bt, bp, bw, bs, bv, ct, ci, cj, cimp, t_stop, max_events):
        """Process events in time order up to t_stop (keys <= t_stop).

        With max_events < 0 it only makes the first predictions of every
        particle at time t_stop (rows all stamped t_stop), for the caller to
        build the calendar from EV[:, KEY].

        Returns DONE, BUFFER_FULL (a record buffer is full: flush and call
        again), CELL_FULL / NL_FULL (grow the cells / neighbour lists and
        call again) or PAUSE (after max_events, for the caller to retune the
        calendar). All loop state lives in the arrays, so a call resumes
        exactly where the last one stopped; a status other than DONE is
        returned before the pending event changes anything (a list rebuild
        may have advanced its particle along its own path first, which the
        event, taken again, does not notice). Records name the
        particles by ID[k], the caller's numbering.

        One iteration: take the earliest key; a stale collision (partner's
        counter changed) only rescans; a collision updates both velocities;
        a wall bounce reflects; a cell crossing moves the particle between
        cells; a neighbour-list rebuild re-centres its list. Then every
        particle whose course or surroundings changed predicts its next
        collision (full scan, or only the new cells after a crossing) and
        its next wall/crossing/rebuild, and goes back in the calendar.
        """
        P = _borrow(P)
        M = _borrow(M)
        TL = _borrow(TL)
        XN = _borrow(XN)
        I = _borrow(I)
        EV = _borrow(EV)
        Q = _borrow(Q)
        HK = _borrow(HK)
        HI = _borrow(HI)
        BH = _borrow(BH)
        cells = _borrow(cells)
        GB = _borrow(GB)
        GS = _borrow(GS)
        NB = _borrow(NB)
        NN = _borrow(NN)
        SCR = _borrow(SCR)
        order = _borrow(order)
        edges = _borrow(edges)
        ID = _borrow(ID)
        bt = _borrow(bt)
        bp = _borrow(bp)
        bw = _borrow(bw)
        bs = _borrow(bs)
        bv = _borrow(bv)
        ct = _borrow(ct)
        ci = _borrow(ci)
        cj = _borrow(cj)
        cimp = _borrow(cimp)
        n = P.shape[0]
        pf = IS[S_PF] != 0  # large systems: prefetch, and gather a collision's scans first
        GROOM = GB.shape[0] // 2  # where j's gather goes in GB when both are gathered first
        cur = IS[S_CUR]
        hsize = IS[S_HSIZE]
        ohead = IS[S_OHEAD]
        nbk = IS[S_NBK]
        nc = IS[S_NC]
        cap = cells.shape[1] - 1
        bufcap = IS[S_BUFCAP]
        recb = IS[S_RECB] != 0
        recc = IS[S_RECC] != 0
        nbb = IS[S_NBB]
        ncb = IS[S_NCB]
        iw = FS[F_IW]
        L = FS[F_L]
        hl = 0.5 * L
        g = FS[F_G]
        e = FS[F_E]
        tc = FS[F_TC]
        inel = e < 1.0  # restitution < 1: a branch taken at collisions only
        h = FS[F_H]
        ainv = nc / L
        virial = FS[F_VIRIAL]
        tstop_b = t_stop * iw
        n_coll = 0
        n_bounce = 0
        n_cross = 0
        n_stale = 0
        n_steps = 0
        n_rebuild = 0
        n_second = 0
        n_overlap = 0
        n_pairs = 0  # pair times computed (the work of the scans)
        done = 0
        tnow = FS[F_TNOW]
        predicting = max_events < 0
        pk = 0
        wb = cur  # the calendar bucket whose list the prefetch walk is in (pf)
        pw = -1  # the walk's particle in it (-1: the list is done)
        status = DONE
        while True:
            # who looks for new events after this one, and where: by default k
            # alone, a full scan, a new crossing time (the event changes these)
            j = -1
            nres = 1
            full = True
            newcross = True
            rescan = True
            lo0 = -1
            hi0 = 1
            lo1 = -1
            hi1 = 1
            lo2 = -1
            hi2 = 1
            if predicting:
                # first predictions: every particle in turn, from time t_stop
                if pk >= n:
                    break
                k = pk
                pk += 1
                t = t_stop
            else:
                # --- the next event: the top of the heap of the current bucket
                if hsize == 0:
                    cur, hsize, ohead, steps = _next_bucket(Q, HK, HI, BH, EV, cur, nbk, iw,
                                                            ohead, tstop_b)
                    n_steps += steps
                if hsize == 0:
                    status = DONE
                    break
                t = HK[0]
                if t > t_stop:
                    status = DONE
                    break
                if done >= max_events:
                    status = PAUSE
                    break
                k = HI[0]
                is_col = EV[k, TCOL] <= EV[k, TX]
                if (recb and nbb >= bufcap) or (recc and ncb >= bufcap):
                    status = BUFFER_FULL
                    break
                code = I[k, CODE]
                # checks that need room, done before anything changes
                rebuild = False
                newcell = -1
                ng = 0
                nn0 = 0
                nn1 = 0
                nn2 = 0
                if NL:
                    rebuild = (not is_col) and code == NLCODE
                if NL and rebuild:
                    # k to time t (written out: an inlined call costs compile time)
                    dta = t - P[k, PT]
                    if dta != 0.0:
                        for a in range(D):
                            P[k, a] += P[k, PV + a] * dta
                        if GRAV:
                            P[k, D - 1] -= 0.5 * g * dta * dta
                            P[k, PV + D - 1] -= g * dta
                        P[k, PT] = t
                    if PER:
                        for a in range(D):
                            if P[k, a] < 0.0 or P[k, a] >= L:
                                P[k, a] -= L * math.floor(P[k, a] / L)
                                if P[k, a] >= L:
                                    P[k, a] = 0.0
                    nn0 = min(max(np.int64(P[k, 0] * ainv), 0), nc - 1)
                    nn1 = min(max(np.int64(P[k, 1] * ainv), 0), nc - 1)
                    if D > 2:
                        nn2 = min(max(np.int64(P[k, 2] * ainv), 0), nc - 1)
                        newcell = (nn0 * nc + nn1) * nc + nn2
                    else:
                        newcell = nn0 * nc + nn1
                    if newcell != I[k, CELL] and cells[newcell, 0] >= cap:
                        status = CELL_FULL
                        break
                    x2 = P[k, 2] if D > 2 else 0.0
                    if pf:
                        # k leaves the lists of its old neighbours below: their rows
                        for s in range(NN[k]):
                            _prefetch_list(NN, NB, NB[k, s])
                    ng = _gather_nl(P, XN, cells, NN, SCR, k, P[k, 0], P[k, 1], x2,
                                    nn0, nn1, nn2, nc, L, h, D, PER, pf)
                    if ng < 0:
                        status = NL_FULL
                        break
                    if pf:
                        # and joins those of its new ones
                        for s in range(ng):
                            _prefetch_list(NN, NB, SCR[s])
                if D > 1 and PAIRS and not NL and not is_col and (code & 1) == 0:
                    d = code >> 2
                    c = I[k, C0 + d] + (1 if (code & 2) else -1)
                    if c < 0:
                        c += nc
                    elif c >= nc:
                        c -= nc
                    st = 1 if d == D - 1 else (nc if d == D - 2 else nc * nc)
                    cell = I[k, CELL] + (c - I[k, C0 + d]) * st
                    if cell != I[k, CELL] and cells[cell, 0] >= cap:
                        status = CELL_FULL
                        break
                hsize = _heap_remove(HK, HI, Q, hsize, 0)
                Q[k, QB] = NONE
                done += 1
                if pf:
                    # the next events are near the top of the heap: start loading
                    # their rows now, they arrive while this event is processed
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
                tnow = t

                # what the event changes, then who must look for new events:
                # k alone (stale prediction, wall, crossing, rebuild) or k and j (collision)
                # k to time t (written out: an inlined call costs compile time)
                dta = t - P[k, PT]
                if dta != 0.0:
                    for a in range(D):
                        P[k, a] += P[k, PV + a] * dta
                    if GRAV:
                        P[k, D - 1] -= 0.5 * g * dta * dta
                        P[k, PV + D - 1] -= g * dta
                    P[k, PT] = t
                if NL and rebuild:
                    # --- re-centre k's neighbour list where k is now
                    n_rebuild += 1
                    for s in range(NN[k]):
                        m = NB[k, s]
                        nm = NN[m]
                        for u in range(nm):
                            if NB[m, u] == k:
                                NB[m, u] = NB[m, nm - 1]
                                NN[m] = nm - 1
                                break
                    old = I[k, CELL]
                    if newcell != old:
                        sl = I[k, SLOT]
                        co = cells[old, 0]
                        last = cells[old, co]
                        cells[old, sl] = last
                        I[last, SLOT] = sl
                        cells[old, 0] = co - 1
                        cn1 = cells[newcell, 0] + 1
                        I[k, SLOT] = cn1
                        cells[newcell, cn1] = k
                        cells[newcell, 0] = cn1
                        I[k, CELL] = newcell
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
                elif is_col:
                    j = I[k, PART]
                    if I[j, CNT] != I[k, PCNT]:
                        # stale: the partner changed course since. If the second
                        # prediction still holds it is the next collision (the
                        # partners that changed since predicted theirs with k
                        # themselves); otherwise look again from now.
                        n_stale += 1
                        newcross = False
                        j2 = I[k, PART2]
                        if j2 >= 0 and I[j2, CNT] == I[k, PCNT2] and I[k, SURE] != 0:
                            n_second += 1
                            # what k's scans did not keep comes after this one,
                            # but the one after it is unknown from now on
                            I[k, SURE] = 0
                            EV[k, TCOL] = EV[k, TCOL2]
                            I[k, PART] = j2
                            I[k, PCNT] = I[k, PCNT2]
                            EV[k, TCOL2] = INF
                            I[k, PART2] = -1
                            rescan = False
                    else:
                        # --- a real collision between k and j at t
                        nres = 2
                        if pf and D > 1 and PAIRS and not NL:
                            _prefetch_block(cells, I[j, C0], I[j, C0 + 1], I[j, C0 + 2],
                                            -1, 1, -1, 1, -1, 1, nc, D)
                        if pf and NL:
                            _prefetch_listed(P, NB, NN, j)
                        hsize, ohead = _q_remove(Q, HK, HI, BH, j, nbk, hsize, ohead)
                        # j to time t (written out: an inlined call costs compile time)
                        dta = t - P[j, PT]
                        if dta != 0.0:
                            for a in range(D):
                                P[j, a] += P[j, PV + a] * dta
                            if GRAV:
                                P[j, D - 1] -= 0.5 * g * dta * dta
                                P[j, PV + D - 1] -= g * dta
                            P[j, PT] = t
                        dx0 = P[j, 0] - P[k, 0]
                        dv0 = P[j, PV] - P[k, PV]
                        dx1 = 0.0
                        dv1 = 0.0
                        dx2 = 0.0
                        dv2 = 0.0
                        if D > 1:
                            dx1 = P[j, 1] - P[k, 1]
                            dv1 = P[j, PV + 1] - P[k, PV + 1]
                        if D > 2:
                            dx2 = P[j, 2] - P[k, 2]
                            dv2 = P[j, PV + 2] - P[k, PV + 2]
                        if PER:
                            dx0 -= L * np.rint(dx0 / L)
                            if D > 1:
                                dx1 -= L * np.rint(dx1 / L)
                            if D > 2:
                                dx2 -= L * np.rint(dx2 / L)
                        bn = dx0 * dv0 + dx1 * dv1 + dx2 * dv2
                        r2 = dx0 * dx0 + dx1 * dx1 + dx2 * dx2
                        if bn < 0.0 and r2 > 0.0:
                            # a pair found already overlapping (beyond round-off) means a
                            # collision was missed: counted, for the tests to watch
                            sg = P[k, PR] + P[j, PR]
                            if r2 < OVERLAP_TOL * sg * sg:
                                n_overlap += 1
                            mk = M[k]
                            mj = M[j]
                            ee = 1.0
                            if inel:
                                if t - TL[k] >= tc and t - TL[j] >= tc:
                                    ee = e
                                TL[k] = t
                                TL[j] = t
                            # impulse on k: J = f dx, f = (1 + e) mu (dv.dx) / |dx|^2
                            f = (1.0 + ee) * mk * mj / (mk + mj) * bn / r2
                            fk = f / mk
                            fj = f / mj
                            P[k, PV] += fk * dx0
                            P[j, PV] -= fj * dx0
                            if D > 1:
                                P[k, PV + 1] += fk * dx1
                                P[j, PV + 1] -= fj * dx1
                            if D > 2:
                                P[k, PV + 2] += fk * dx2
                                P[j, PV + 2] -= fj * dx2
                            jmag = -f * math.sqrt(r2)
                            virial += jmag * sg
                            I[k, CNT] += 1
                            I[j, CNT] += 1
                            n_coll += 1
                            if recc:
                                ct[ncb] = t
                                ci[ncb] = ID[k]
                                cj[ncb] = ID[j]
                                cimp[ncb] = jmag
                                ncb += 1
                else:
                    d = code >> 2
                    up = (code & 2) != 0
                    if code & 1:
                        # --- a wall bounce
                        vd = P[k, PV + d]
                        if recb:
                            sp = P[k, PV] * P[k, PV]
                            for a in range(1, D):
                                sp += P[k, PV + a] * P[k, PV + a]
                            bt[nbb] = t
                            bp[nbb] = ID[k]
                            bw[nbb] = (d + 1) if up else -(d + 1)
                            bs[nbb] = math.sqrt(sp)
                            bv[nbb] = abs(vd)
                            nbb += 1
                        P[k, d] = (L - P[k, PR]) if up else P[k, PR]
                        P[k, PV + d] = -vd
                        I[k, CNT] += 1
                        n_bounce += 1
                    elif D > 1 and PAIRS and not NL:
                        # --- a cell crossing (D > 1), wrapping around a periodic box
                        n_cross += 1
                        full = False
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
                        P[k, d] = xn
                        if cn != c:
                            old = I[k, CELL]
                            st = 1 if d == D - 1 else (nc if d == D - 2 else nc * nc)
                            cell = old + (cn - c) * st
                            sl = I[k, SLOT]
                            co = cells[old, 0]
                            last = cells[old, co]
                            cells[old, sl] = last
                            I[last, SLOT] = sl
                            cells[old, 0] = co - 1
                            cn1 = cells[cell, 0] + 1
                            I[k, SLOT] = cn1
                            cells[cell, cn1] = k
                            cells[cell, 0] = cn1
                            I[k, CELL] = cell
                            I[k, C0 + d] = cn
                        # only the cells that just came into view
                        o = 1 if up else -1
                        if d == 0:
                            lo0 = o
                            hi0 = o
                        elif d == 1:
                            lo1 = o
                            hi1 = o
                        else:
                            lo2 = o
                            hi2 = o

            # --- new predictions for k (and j), in steps: a gather of a side's
            # cells, then the rest for that side. Large systems (pf) gather both
            # sides first (a collision's second gather requests its rows from
            # memory before the first scan waits on its own), small ones gather
            # each just before its scan (faster in cache). One step loop keeps a
            # single copy of each inlined helper (compile time).
            cellscan = PAIRS and D > 1 and not NL and rescan
            ng0 = 0
            ng1 = 0
            for step in range(2 * nres if cellscan else nres):
                if not cellscan:
                    side = step
                    gathering = False
                elif pf:
                    side = step % nres
                    gathering = step < nres
                else:
                    side = step // 2
                    gathering = step % 2 == 0
                p = k if side == 0 else j
                base = side * GROOM if pf else 0
                if gathering:
                    ng = _gather_cells(P, I, cells, GB, GS, base, I[p, C0], I[p, C0 + 1],
                                       I[p, C0 + 2], lo0, hi0, lo1, hi1, lo2, hi2, nc, D, PER,
                                       IMG, pf)
                    if side == 0:
                        ng0 = ng
                    else:
                        ng1 = ng
                    continue
                if newcross:
                    tx, cd = _crossing(P, I, edges, p, nc, n, L, g, D, PER, GRAV, PAIRS, NL)
                    if NL:
                        te = _nl_exit(P, XN, p, h, g, D, GRAV)
                        if te < tx:
                            tx = te
                            cd = NLCODE
                    EV[p, TX] = tx
                    I[p, CODE] = cd
                if PAIRS and (D == 1 or NL) and rescan:
                    if D == 1:
                        best, bj = _scan_1d(P, order, p, I[p, RANK], n, t, L, g, PER, GRAV)
                        n_pairs += 2
                    else:
                        best, bj = _scan_nl(P, NB, NN, p, t, L, hl, g, INF, -1, D, PER, GRAV, pf)
                        n_pairs += NN[p]
                    EV[p, TCOL] = best
                    I[p, PART] = bj
                    I[p, PCNT] = I[bj, CNT] if bj >= 0 else 0
                if cellscan:
                    # a full scan, or the cells that came into view merged
                    # with the two predictions kept (which keep the counter
                    # they were made with; a new one takes the partner's
                    # counter now, even when the partner is the same: the
                    # kept prediction with it may be stale, the new one not)
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
                    ng = ng0 if side == 0 else ng1
                    best, bj, src1, best2, bj2, src2 = _scan_gathered(
                        P, GB, GS, base, ng, p, t, L, g, b1, p1, b2, p2, D, PER, GRAV, IMG)
                    n_pairs += ng
                    EV[p, TCOL] = best
                    I[p, PART] = bj
                    if bj < 0:
                        I[p, PCNT] = 0
                    elif src1 == NEW:
                        I[p, PCNT] = I[bj, CNT]
                    else:
                        I[p, PCNT] = oc1 if src1 == KEPT1 else oc2
                    EV[p, TCOL2] = best2
                    I[p, PART2] = bj2
                    if full:
                        I[p, SURE] = 1
                    if bj2 < 0:
                        I[p, PCNT2] = 0
                    elif src2 == NEW:
                        I[p, PCNT2] = I[bj2, CNT]
                    else:
                        I[p, PCNT2] = oc1 if src2 == KEPT1 else oc2
                key = min(EV[p, TCOL], EV[p, TX])
                EV[p, KEY] = key
                if not predicting:
                    hsize, ohead = _q_insert(Q, HK, HI, BH, p, key, cur, nbk, iw, hsize, ohead)
            if pf and not predicting:
                # the list of the next bucket is walked one particle an event (each
                # step reads a row requested one event before), from when the current
                # bucket went into the heap, so that moving it into the heap in turn
                # does not wait on one cache miss after another
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
                    # the next event's particle: its rows were requested one event
                    # ago; now its cells and its partner's rows
                    kn = HI[0]
                    if D > 1 and PAIRS and not NL:
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

        IS[S_CUR] = cur
        IS[S_HSIZE] = hsize
        IS[S_OHEAD] = ohead
        IS[S_NBB] = nbb
        IS[S_NCB] = ncb
        IS[S_EVENTS] += done
        IS[S_COLL] += n_coll
        IS[S_BOUNCE] += n_bounce
        IS[S_CROSS] += n_cross
        IS[S_STALE] += n_stale
        IS[S_STEPS] += n_steps
        IS[S_REBUILD] += n_rebuild
        IS[S_SECOND] += n_second
        IS[S_OVERLAP] += n_overlap
        IS[S_PAIRS] += n_pairs
        FS[F_VIRIAL] = virial
        FS[F_TNOW] = tnow
        return status

    class Kernels:
        """The specialised kernels of one kind of scene."""

    ns = Kernels()
    ns.loop = loop
    ns.flags = (D, PER, GRAV, PAIRS, NL, IMG)
    return ns
