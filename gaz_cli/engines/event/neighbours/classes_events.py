"""Cells per size class at the event loop's steps (:mod:`.classes` says how the classes
work): a particle's partners to scan, whether a crossing finds room, the crossing itself.

Inlined into the loop built with ``MIX`` (:func:`.loop.build`).
"""

from __future__ import annotations

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import C0, CELL, PR
from gaz_cli.engines.event.neighbours.ball import _ball_walk, _far, _image
from gaz_cli.engines.event.neighbours.cells import _face_beyond, _gather_cells, _move, _stride


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
def _gather_large_near(I, CL, GB, GS, w, c0, c1, c2, full, d, up, nc, ncl, f, bcl, rint, D, PER,
                       IMG):
    """A small particle in fine cell c: the large particles adjacent to it (full), or those
    that became adjacent when it crossed into c along axis d (up: from below), appended to
    GB at w (IMG: their image codes in GS); the new end. Looks in the coarse cells holding
    the fine ones within bcl."""
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
                code = 0
                if IMG:
                    code = 9 * _image(q0, ncl) + 3 * _image(q1, ncl) + (_image(q2, ncl) if D > 2 else 1)
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
                    if IMG:
                        GS[w] = code
                    w += 1
    return w


@_inline
def _gather_classes(P, I, cells, CL, CV, GB, GS, base, p, full, d, up, moved, lo0, hi0, lo1,
                    hi1, lo2, hi2, nc, ncl, f, bcl, rint, rcut, D, PER, IMG):
    """Particle p's partners to scan, gathered into GB[base:]; their number.

    A full scan (after a collision, a bounce, a stale prediction) or, after p crossed into
    its fine cell along axis d (up: from below), the partners that came into view; lo..hi the
    block of p's own grid to gather (3^D, or the layer entered: :func:`.cells._block_entered`).
    Small p: the small particles of that fine block, the large ones adjacent (full) or just
    become adjacent, looked up only where some large particle is near (CV). Large p: the
    large particles of that coarse block (at a crossing, only
    when p changed coarse cell: ``moved``), the small ones of its ball or of the ball's front.
    IMG (a periodic coarse grid of three cells an axis, where the block's image of a particle
    need not be the nearest): every particle gathered with its image code in GS.
    """
    c0 = I[p, C0]
    c1 = I[p, C0 + 1]
    c2 = I[p, C0 + 2] if D > 2 else 0
    if P[p, PR] <= rcut:
        w = base + _gather_cells(P, I, cells, GB, GS, base, c0, c1, c2, lo0, hi0, lo1, hi1,
                                 lo2, hi2, nc, D, PER, IMG, False)
        if CV[I[p, CELL]] > 0:
            w = _gather_large_near(I, CL, GB, GS, w, c0, c1, c2, full, d, up, nc, ncl, f, bcl,
                                   rint, D, PER, IMG)
    else:
        w = base
        if full or moved:
            w += _gather_cells(P, I, CL, GB, GS, base, c0 // f, c1 // f, c2 // f, lo0, hi0, lo1,
                               hi1, lo2, hi2, ncl, D, PER, IMG, False)
        w = _ball_walk(cells, GB, GS, w, CV, c0, c1, c2, full, d, up, nc, bcl, rint, D, PER, IMG,
                       False)
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
            _ball_walk(cells, CV, CV, 0, CV, I[k, C0], I[k, C0 + 1], I[k, C0 + 2] if D > 2 else 0,
                       False, d, up, nc, bcl, rint, D, PER, False, True)
    return moved
