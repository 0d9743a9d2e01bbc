"""Cells per size class (2D/3D mixtures of very different sizes): a fine grid for the small
particles, a coarse one for the large, each pair found in the grid that fits it.

With one grid, cells are as wide as the largest pair reach, so a 1:100 mixture scans
thousands of small particles at every event (4,414 pair tests per event in 2D, issue 15).
Here (a two-level hierarchical grid, after Ogarko & Luding, Comput. Phys. Commun. 183, 931,
2012, made exact for event-driven dynamics):

* every particle has fine cell coordinates (columns C0.. of I) and crosses the fine cells'
  faces: the fine grid is sized for the small particles (cells at least one small-small
  reach wide, at most CELLS_PER_PARTICLE per small particle, as :mod:`.sizing` does);
* the small particles sit in the fine cell table (``cells``); the large ones in a coarse
  table (``CL``) whose cells are ``f`` fine cells an axis, at least one large-large reach
  wide; for a large particle, I[CELL] and I[SLOT] are its coarse cell and slot;
* small-small pairs are found as with one grid (3^D fine cells, the layer entered at a
  crossing); large-large pairs likewise on the coarse grid (the coarse layer entered when
  a fine crossing changes the coarse cell);
* a small and a large particle are *adjacent* when their fine cells could hold two centres
  within reach: sum over the axes of max(0, |dc| - 1)^2 <= RINT (dc the difference of fine
  coordinates, RINT = floor((reach / a)^2), reach = r_small,max + r_large,max). A pair in
  contact is adjacent, and adjacency changes only when one of the two crosses a fine face.
  So each finds the other (a) at its full scans (after a collision or a bounce: every
  partner adjacent now) and (b) at its crossings (the partners that just became adjacent):
  a small particle looks up the few large ones in the coarse cells around it; a large one
  scans the fine cells of a rounded ball of radius ~reach around it (full), or only the
  ball's front (crossing: one cell per column along the axis crossed). Every pair that can
  meet is thus predicted by one of the two, or one of them looks again before (the
  invariant of :mod:`.loop`);
* each fine cell counts the large particles whose ball holds it (``CV``, moved with their
  crossings): a small particle looks up the coarse cells only where that count is not 0.

A large particle's full scan costs the fine cells of its ball, ~(2 reach / a)^D, instead of
the small particles of 3^D coarse cells; its crossings, ~(2 reach / a)^(D-1) cells; a small
particle's events add a look at the large ones of at most 3^D coarse cells.

:func:`plan` decides (sizing's door for mixtures) and sizes; the kernels below are inlined
into the loop built with ``MIX`` (:func:`.loop.build`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from gaz_cli.engine.intrinsics import _inline
from gaz_cli.engine.memory import _alloc
from gaz_cli.engine.layout import C0, CELL, CELL_FULL, DONE, GATHER_SLOTS, PR
from gaz_cli.engine.neighbours.cells import _face_beyond, _gather_cells, _move, _put, _stride, wider
from gaz_cli.numba_config import njit

MIN_RATIO = 8.0
"""Size classes from this ratio of the largest radius to the largest small radius on
(a particle is small when its radius is at most rmax / MIN_RATIO). Below it the coarse grid
holds few small particles a cell and one grid costs less than two (the 1:5 mixture of the
engine's tests keeps one grid)."""

Plan = namedtuple("Plan", ["nc", "ncl", "f", "rint", "bcl", "rcut", "n_small", "n_large"])
"""Two size classes: fine cells an axis nc, coarse cells an axis ncl of f fine cells each,
the adjacency bound RINT and the ball's half-width bcl = 1 + isqrt(RINT) (fine cells), the
largest small radius rcut (m), the particles of each class."""


def plan(radii: np.ndarray, D: int, L: float, periodic: bool, pairs: bool, use_nl: bool,
         reach, cells_per_axis) -> Plan | None:
    """The two size classes of a scene, or None when one grid fits it.

    radii (N,) m; ``reach(r)`` the pair reach of two particles of radius r
    (:func:`.interactions.pair_reach`); ``cells_per_axis`` sizing's rule for one grid. None
    in 1D, with neighbour lists, without pairs, when the radii span less than MIN_RATIO,
    or when a periodic box is too small for the fine ball or for four coarse cells.
    """
    if not pairs or D == 1 or use_nl:
        return None
    radii = np.asarray(radii, dtype=np.float64)
    rmax = float(radii.max())
    small = radii <= rmax / MIN_RATIO
    n_small = int(small.sum())
    if n_small == 0 or n_small == radii.size:
        return None
    rs = float(radii[small].max())
    if rs <= 0.0:
        return None
    reach_ss, reach_ll = reach(rs), reach(rmax)
    reach_sl = 0.5 * (reach_ss + reach_ll)
    nc = cells_per_axis(D, n_small, L, True, periodic, reach_ss, 0.0, False)

    def bounds(nc):
        a = L / nc
        rint = int(math.floor((reach_sl / a * (1.0 + 1e-9)) ** 2))
        bcl = 1 + math.isqrt(rint)
        f = max(int(math.ceil(reach_ll / a * (1.0 + 1e-9))), bcl)
        return rint, bcl, f

    rint, bcl, f = bounds(nc)
    if periodic:
        ncl = nc // f
        if ncl < 4:
            return None
        nc = ncl * f  # whole coarse cells around the box (wider fine cells: f, B hold)
        rint, bcl, _ = bounds(nc)
        if nc < 2 * bcl + 3:
            return None
    else:
        ncl = -(-nc // f)
    return Plan(nc, ncl, f, rint, bcl, rs, n_small, radii.size - n_small)


def ball_cells(D: int, rint: int) -> int:
    """Fine cells in a large particle's ball (its full scan)."""
    b = 1 + math.isqrt(rint)
    g = [max(0, abs(x) - 1) ** 2 for x in range(-b, b + 1)]
    if D == 2:
        return sum(1 for x in g for y in g if x + y <= rint)
    return sum(1 for x in g for y in g for z in g if x + y + z <= rint)


# --- kernels ----------------------------------------------------------------
@_inline
def _isqrt(x):
    """The integer square root of x >= 0 (floor of its square root)."""
    r = np.int64(math.sqrt(x))
    while (r + 1) * (r + 1) <= x:
        r += 1
    while r * r > x:
        r -= 1
    return r


@_inline
def _far(o):
    """max(0, |o| - 1)^2: the least squared distance, in fine cells, of two points in cells o
    apart along an axis."""
    u = abs(o) - 1
    return u * u if u > 0 else 0


@_inline
def _apart(c, nc, PER):
    """A difference of fine coordinates c, the periodic image nearest to 0 when PER."""
    if PER:
        if 2 * c > nc:
            return c - nc
        if 2 * c < -nc:
            return c + nc
    return c


@_inline
def _at(c, nc, PER):
    """(the cell coordinate c in the box, whether there is such a cell): wrapped around a
    periodic box, none beyond a wall."""
    if PER:
        return c % nc, True
    return c, 0 <= c < nc


@_inline
def _add_cell(cells, GB, w, cell):
    """The particles of one cell appended to GB at w; the new end."""
    for s in range(1, cells[cell, 0] + 1):
        GB[w] = cells[cell, s]
        w += 1
    return w


@_inline
def _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER):
    """(the index of the fine cell c + o, whether there is one: none beyond a wall)."""
    n0, in0 = _at(c0 + o0, nc, PER)
    n1, in1 = _at(c1 + o1, nc, PER)
    n2 = 0
    in2 = True
    if D > 2:
        n2, in2 = _at(c2 + o2, nc, PER)
    cell = (n0 * nc + n1) * nc + n2 if D > 2 else n0 * nc + n1
    return cell, in0 and in1 and in2


@_inline
def _add_fine(cells, GB, w, c0, c1, c2, o0, o1, o2, nc, D, PER):
    """The particles of the fine cell c + o appended to GB at w (none beyond a wall)."""
    cell, there = _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER)
    if there:
        w = _add_cell(cells, GB, w, cell)
    return w


@_inline
def _column(d, p, q, od):
    """The offsets (o0, o1, o2) of a cell od along axis d, p and q along the other two."""
    if d == 0:
        return od, p, q
    if d == 1:
        return p, od, q
    return p, q, od


@_inline
def _cover_move(CV, c0, c1, c2, d, up, nc, bcl, rint, D, PER):
    """A large particle moved into fine cell c along axis d (up: from below): the cells of its
    ball's front count one more large particle near (CV), those its ball left one fewer.
    Per column along d, the ball spans |o| <= m: the front is at o = +m (up), the cell left at
    o = -(m + 1), relative to the new cell."""
    b2 = bcl if D > 2 else 0
    sgn = 1 if up else -1
    for p in range(-bcl, bcl + 1):
        sp = _far(p)
        if sp > rint:
            continue
        for q in range(-b2, b2 + 1):
            sq = sp + _far(q)
            if sq > rint:
                continue
            m = 1 + _isqrt(rint - sq)
            o0, o1, o2 = _column(d, p, q, sgn * m)
            cell, there = _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER)
            if there:
                CV[cell] += 1
            o0, o1, o2 = _column(d, p, q, -sgn * (m + 1))
            cell, there = _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER)
            if there:
                CV[cell] -= 1


@_inline
def _gather_ball(cells, GB, w, c0, c1, c2, full, d, up, nc, bcl, rint, D, PER):
    """A large particle in fine cell c: the small particles of its ball (full: every fine cell
    adjacent to c), or of the cells that became adjacent when it crossed into c along axis d
    (up: from below), appended to GB at w; the new end.

    The front of a crossing is one cell per column along d: for the other axes' offsets,
    with S their sum of _far, the adjacent cells along d are |o| <= m = 1 + isqrt(RINT - S),
    and moving by one brings in o = +m (up) or -m alone.
    """
    b2 = bcl if D > 2 else 0
    if full:
        for o0 in range(-bcl, bcl + 1):
            s0 = _far(o0)
            if s0 > rint:
                continue
            for o1 in range(-bcl, bcl + 1):
                s1 = s0 + _far(o1)
                if s1 > rint:
                    continue
                for o2 in range(-b2, b2 + 1):
                    if s1 + _far(o2) > rint:
                        continue
                    w = _add_fine(cells, GB, w, c0, c1, c2, o0, o1, o2, nc, D, PER)
        return w
    # the front: (p, q) the offsets along the other axes
    for p in range(-bcl, bcl + 1):
        sp = _far(p)
        if sp > rint:
            continue
        for q in range(-b2, b2 + 1):
            sq = sp + _far(q)
            if sq > rint:
                continue
            m = 1 + _isqrt(rint - sq)
            o0, o1, o2 = _column(d, p, q, m if up else -m)
            w = _add_fine(cells, GB, w, c0, c1, c2, o0, o1, o2, nc, D, PER)
    return w


@_inline
def _coarse_span(c, lo, hi, nc, f, PER):
    """The coarse coordinates (first, last) holding the fine ones c + lo .. c + hi (clipped
    at walls; with PER, unwrapped: the caller wraps them); first > last if none."""
    a = c + lo
    b = c + hi
    if not PER:
        a = max(a, 0)
        b = min(b, nc - 1)
        if a > b:
            return 1, 0
    return a // f, b // f


@_inline
def _gather_large_near(I, CL, GB, w, c0, c1, c2, full, d, up, nc, ncl, f, bcl, rint, D, PER):
    """A small particle in fine cell c: the large particles adjacent to it (full), or those
    that became adjacent when it crossed into c along axis d (up: from below), appended to
    GB at w; the new end. Looks in the coarse cells holding the fine ones within bcl."""
    lo0, hi0, lo1, hi1, lo2, hi2 = -bcl, bcl, -bcl, bcl, -bcl, bcl
    if not full:
        # a large particle that just became adjacent lies ahead along d
        if d == 0:
            lo0, hi0 = (1, bcl) if up else (-bcl, -1)
        elif d == 1:
            lo1, hi1 = (1, bcl) if up else (-bcl, -1)
        else:
            lo2, hi2 = (1, bcl) if up else (-bcl, -1)
    a0, b0 = _coarse_span(c0, lo0, hi0, nc, f, PER)
    a1, b1 = _coarse_span(c1, lo1, hi1, nc, f, PER)
    a2, b2 = 0, 0
    if D > 2:
        a2, b2 = _coarse_span(c2, lo2, hi2, nc, f, PER)
    step = 1 if up else -1  # the crossing particle's move along d
    for q0 in range(a0, b0 + 1):
        n0 = q0 % ncl if PER else q0
        for q1 in range(a1, b1 + 1):
            n1 = q1 % ncl if PER else q1
            for q2 in range(a2, b2 + 1):
                n2 = q2 % ncl if PER else q2
                cell = (n0 * ncl + n1) * ncl + n2 if D > 2 else n0 * ncl + n1
                for s in range(1, CL[cell, 0] + 1):
                    m = CL[cell, s]
                    e0 = _apart(I[m, C0] - c0, nc, PER)
                    e1 = _apart(I[m, C0 + 1] - c1, nc, PER)
                    e2 = _apart(I[m, C0 + 2] - c2, nc, PER) if D > 2 else 0
                    sn = _far(e0) + _far(e1) + _far(e2)
                    if sn > rint:
                        continue
                    if not full:
                        # adjacent before the move? (the difference was one more along d)
                        if d == 0:
                            so = sn - _far(e0) + _far(e0 + step)
                        elif d == 1:
                            so = sn - _far(e1) + _far(e1 + step)
                        else:
                            so = sn - _far(e2) + _far(e2 + step)
                        if so <= rint:
                            continue
                    GB[w] = m
                    w += 1
    return w


@_inline
def _gather_classes(P, I, cells, CL, CV, GB, GS, base, p, full, d, up, moved, lo0, hi0, lo1,
                    hi1, lo2, hi2, nc, ncl, f, bcl, rint, rcut, D, PER):
    """Particle p's partners to scan, gathered into GB[base:]; their number.

    A full scan (after a collision, a bounce, a stale prediction) or, after p crossed into
    its fine cell along axis d (up: from below), the partners that came into view; lo..hi the
    block of p's own grid to gather (3^D, or the layer entered: :func:`.cells._block_entered`).
    Small p: the small particles of that fine block, the large ones adjacent (full) or just
    become adjacent, looked up only where some large particle is near (CV). Large p: the
    large particles of that coarse block (at a crossing, only
    when p changed coarse cell: ``moved``), the small ones of its ball or of the ball's front.
    """
    c0 = I[p, C0]
    c1 = I[p, C0 + 1]
    c2 = I[p, C0 + 2] if D > 2 else 0
    if P[p, PR] <= rcut:
        w = base + _gather_cells(P, I, cells, GB, GS, base, c0, c1, c2, lo0, hi0, lo1, hi1,
                                 lo2, hi2, nc, D, PER, False, False)
        if CV[I[p, CELL]] > 0:
            w = _gather_large_near(I, CL, GB, w, c0, c1, c2, full, d, up, nc, ncl, f, bcl, rint,
                                   D, PER)
    else:
        w = base
        if full or moved:
            w += _gather_cells(P, I, CL, GB, GS, base, c0 // f, c1 // f, c2 // f, lo0, hi0, lo1,
                               hi1, lo2, hi2, ncl, D, PER, False, False)
        w = _gather_ball(cells, GB, w, c0, c1, c2, full, d, up, nc, bcl, rint, D, PER)
    return w - base


@_inline
def _room_to_cross(P, I, cells, CL, k, code, nc, f, ncl, rcut, D):
    """Whether particle k's crossing ``code`` finds room in the cell it enters (its fine cell,
    small; its coarse cell, large, if it changes)."""
    d = code >> 2
    c = I[k, C0 + d]
    cn = c + (1 if (code & 2) else -1)
    if cn < 0:
        cn += nc
    elif cn >= nc:
        cn -= nc
    if P[k, PR] <= rcut:
        new = I[k, CELL] + (cn - c) * _stride(d, nc, D)
        return new == I[k, CELL] or cells[new, 0] < cells.shape[1] - 1
    if cn // f == c // f:
        return True
    new = I[k, CELL] + (cn // f - c // f) * _stride(d, ncl, D)
    return CL[new, 0] < CL.shape[1] - 1


@_inline
def _cross_face_classes(P, I, cells, CL, CV, edges, k, d, up, nc, f, ncl, bcl, rint, L, rcut, D,
                        PER):
    """Particle k crosses the face of its fine cell along axis d (up: the one above), as
    :func:`.cells._cross_face`; a large particle moves its ball's counts (CV), and moves in
    the coarse table when its coarse cell changes. Whether it did (a large particle's coarse
    layer to scan)."""
    c, cn, xn = _face_beyond(I, edges, k, d, up, nc, L)
    P[k, d] = xn
    moved = False
    if cn != c:
        if P[k, PR] <= rcut:
            _move(cells, I, k, I[k, CELL] + (cn - c) * _stride(d, nc, D))
        elif cn // f != c // f:
            _move(CL, I, k, I[k, CELL] + (cn // f - c // f) * _stride(d, ncl, D))
            moved = True
        I[k, C0 + d] = cn
        if P[k, PR] > rcut:
            _cover_move(CV, I[k, C0], I[k, C0 + 1], I[k, C0 + 2] if D > 2 else 0, d, up, nc,
                        bcl, rint, D, PER)
    return moved


@njit
def _assign_classes(P, I, cells, CL, nc, a, f, ncl, rcut, D):
    """Every particle's fine coordinates (cells of side a, nc an axis); the small ones into
    their fine cell, the large ones into their coarse cell (f fine cells an axis, ncl an
    axis). Status CELL_FULL if a cell overflows."""
    n = P.shape[0]
    cap = cells.shape[1] - 1
    capl = CL.shape[1] - 1
    cells[:, 0] = 0
    CL[:, 0] = 0
    for k in range(n):
        cell = 0
        coarse = 0
        for d in range(D):
            c = int(math.floor(P[k, d] / a))
            if c < 0:
                c = 0
            elif c >= nc:
                c = nc - 1
            I[k, C0 + d] = c
            cell = cell * nc + c
            coarse = coarse * ncl + c // f
        if not (_put(I, cells, k, cell, cap) if P[k, PR] <= rcut else _put(I, CL, k, coarse, capl)):
            return CELL_FULL
    return DONE


@njit
def _cover_fill(P, I, CV, nc, bcl, rint, rcut, D, PER):
    """CV[cell]: how many large particles have the fine cell in their ball (the cells where a
    small particle has large ones to look up)."""
    CV[:] = 0
    b2 = bcl if D > 2 else 0
    for k in range(P.shape[0]):
        if P[k, PR] <= rcut:
            continue
        c0 = I[k, C0]
        c1 = I[k, C0 + 1]
        c2 = I[k, C0 + 2] if D > 2 else 0
        for o0 in range(-bcl, bcl + 1):
            for o1 in range(-bcl, bcl + 1):
                for o2 in range(-b2, b2 + 1):
                    if _far(o0) + _far(o1) + _far(o2) > rint:
                        continue
                    cell, there = _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER)
                    if there:
                        CV[cell] += 1


# --- the Python side: tables and buffers -------------------------------------
def fill(rows, P, I) -> None:
    """The fine and coarse tables of ``rows`` (:class:`.rows.Rows` with ``mix`` a
    :class:`Plan`) for its rows P, I: rows.cells, rows.CL, rows.cap, grown until all fit."""
    from gaz_cli.engine import sizing

    mx = rows.mix
    D, n, nc = rows.D, rows.n, mx.nc
    small = P[:, PR] <= mx.rcut
    c = rows._cell_coords(P[:, :D])
    key = c[:, 0]
    keyl = c[:, 0] // mx.f
    for d in range(1, D):
        key = key * nc + c[:, d]
        keyl = keyl * mx.ncl + c[:, d] // mx.f
    full_s = int(np.bincount(key[small], minlength=1).max()) if small.any() else 0
    full_l = int(np.bincount(keyl[~small], minlength=1).max()) if (~small).any() else 0
    cap = max(rows.cap, sizing._cell_capacity(mx.n_small / nc ** D), full_s)
    capl = max(getattr(rows, "capl", 0), sizing._cell_capacity(mx.n_large / mx.ncl ** D),
               full_l)
    while True:
        rows.cells = _alloc((nc ** D, sizing._cell_width(cap)), np.int32)
        rows.CL = _alloc((mx.ncl ** D, sizing._cell_width(capl)), np.int32)
        if _assign_classes(P, I, rows.cells, rows.CL, nc, rows.L / nc, mx.f, mx.ncl, mx.rcut,
                           D) == DONE:
            break
        cap *= 2
        capl *= 2
    rows.cap = rows.cells.shape[1] - 1
    rows.capl = rows.CL.shape[1] - 1
    rows.CV = _alloc(nc ** D, np.int32)
    _cover_fill(P, I, rows.CV, nc, mx.bcl, mx.rint, mx.rcut, D, rows.periodic)


def grow(rows) -> None:
    """A full cell: the coarse table with twice the room (rows._grow_cells grows the fine one)."""
    rows.CL = wider(rows.CL)
    rows.capl = rows.CL.shape[1] - 1


def gather_room(rows) -> int:
    """Room in GB for one scan: a small particle's 3^D fine cells and 3^D coarse ones, or a
    large one's 3^D coarse cells and its ball; plus the slots a gather copies beyond."""
    mx = rows.mix
    caps = rows.cells.shape[1] - 1
    capl = rows.CL.shape[1] - 1
    near = 3 ** rows.D
    return (max(near * (caps + capl), near * capl + ball_cells(rows.D, mx.rint) * caps)
            + GATHER_SLOTS + 1)
