"""A large particle's ball of fine cells (cells per size class, :mod:`.classes`).

A small and a large particle are *adjacent* when their fine cells could hold two centres
within reach: sum over the axes of _far(dc) <= RINT (dc the difference of fine coordinates,
_far(o) = max(0, |o| - 1)^2, RINT = floor((reach / a)^2)). The fine cells adjacent to a
large particle's cell c are its *ball*: offsets o with |o_d| <= bcl = 1 + isqrt(RINT) on each
axis and sum of _far(o_d) <= RINT. Seen along an axis d, the ball is a set of columns: for
the offsets (p, q) along the other two axes, with S = _far(p) + _far(q) <= RINT, the cells
|o_d| <= m = 1 + isqrt(RINT - S). When the particle moves by one fine cell along d (up:
from below), the cell at o_d = +m of each column enters its ball (-m, moving down) and the
one at -(m + 1) leaves it (+(m + 1)): the ball's *front* and *back*.

One walk of that geometry, :func:`_ball_walk`: every cell of the ball, or its front (and
back), either gathering the small particles of the cells it walks (a large particle's scan)
or counting the large particle in them (``CV``: how many large particles hold a fine cell in their ball; a small particle looks
up the large ones only where that count is not 0). :func:`_cover_fill` fills the counts.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import C0, PR
from gaz_cli.numba_config import njit


@functools.lru_cache(maxsize=64)
def ball_cells(D: int, rint: int) -> int:
    """Fine cells in a large particle's ball (its full scan): for each offset along the
    first D - 1 axes with S = sum of _far <= RINT, a column of 3 + 2 isqrt(RINT - S) cells
    (|o| <= 1 + isqrt(RINT - S) along the last axis)."""
    b = 1 + math.isqrt(rint)
    g = [_far.py_func(x) for x in range(-b, b + 1)]
    heads = g if D == 2 else [x + y for x in g for y in g]
    return sum(3 + 2 * math.isqrt(rint - s) for s in heads if s <= rint)


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
def _at(c, nc, PER):
    """(the cell coordinate c in the box, whether there is such a cell): wrapped around a
    periodic box, none beyond a wall."""
    if PER:
        return c % nc, True
    return c, 0 <= c < nc


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
def _image(u, n):
    """The image of an unwrapped cell coordinate u (one wrap at most) of a periodic grid of n
    cells an axis: 0, 1, 2 for a shift of -L, 0, +L (the code of :func:`.cells._gather_cells`)."""
    if u < 0:
        return 0
    if u >= n:
        return 2
    return 1


@_inline
def _visit(cells, GB, GS, w, CV, c0, c1, c2, o0, o1, o2, nc, D, PER, IMG, COUNT, delta):
    """The fine cell c + o, if there is one: CV[cell] += delta (COUNT), or its particles
    appended to GB at w (IMG: with the image code of the cell in GS). The new end of GB."""
    cell, there = _cell_at(c0, c1, c2, o0, o1, o2, nc, D, PER)
    if there:
        if COUNT:
            CV[cell] += delta
        else:
            code = 0
            if IMG:
                code = 9 * _image(c0 + o0, nc) + 3 * _image(c1 + o1, nc)
                code += _image(c2 + o2, nc) if D > 2 else 1
            for s in range(1, cells[cell, 0] + 1):
                GB[w] = cells[cell, s]
                if IMG:
                    GS[w] = code
                w += 1
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
def _ball_walk(cells, GB, GS, w, CV, c0, c1, c2, whole, d, up, nc, bcl, rint, D, PER, IMG, COUNT):
    """Walk a large particle's ball around fine cell c, column by column: the whole ball
    (``whole``), or its front after a move into c along axis d (up: from below). Each cell
    walked has its particles appended to GB at w (IMG: their image codes in GS, for a
    periodic coarse grid of three cells an axis), or (COUNT) one more large particle counted
    in CV, and the front's walk then counts one fewer in the ball's back (with COUNT, cells and
    GB are not read). The new end of GB.

    The whole ball is walked along the last axis, in the order of the offsets (o0, o1, o2):
    the order a scan gathers in."""
    b2 = bcl if D > 2 else 0
    if whole:
        d = D - 1
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
            if whole:
                for od in range(-m, m + 1):
                    o0, o1, o2 = _column(d, p, q, od)
                    w = _visit(cells, GB, GS, w, CV, c0, c1, c2, o0, o1, o2, nc, D, PER, IMG, COUNT, 1)
                continue
            o0, o1, o2 = _column(d, p, q, sgn * m)
            w = _visit(cells, GB, GS, w, CV, c0, c1, c2, o0, o1, o2, nc, D, PER, IMG, COUNT, 1)
            if COUNT:
                o0, o1, o2 = _column(d, p, q, -sgn * (m + 1))
                w = _visit(cells, GB, GS, w, CV, c0, c1, c2, o0, o1, o2, nc, D, PER, IMG, COUNT, -1)
    return w


@njit
def _cover_fill(P, I, CV, nc, bcl, rint, rcut, D, PER):
    """CV[cell]: how many large particles have the fine cell in their ball (the cells where a
    small particle has large ones to look up)."""
    CV[:] = 0
    for k in range(P.shape[0]):
        if P[k, PR] > rcut:
            _ball_walk(CV, CV, CV, 0, CV, I[k, C0], I[k, C0 + 1], I[k, C0 + 2] if D > 2 else 0, True,
                       0, True, nc, bcl, rint, D, PER, False, True)
