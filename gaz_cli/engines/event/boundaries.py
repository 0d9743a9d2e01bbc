"""What bounds the box: hard walls (bounce events) and the periodic box (wrap, images).

A wall bounce puts the centre exactly on the wall plane, a crossing exactly on the cell
face; a particle past a wall and moving out bounces at once. Along the gravity axis the
times come from the stable quadratic forms of physics.md section 10.

Off the gravity axis, :func:`_crossing` picks the face ahead and its time by selects,
not by branches on the sign of the velocity (a coin toss for the predictor, three times
an event); the same values, in less time (measurements:
docs/explanation/engine_measurements.md#event-engine-boundaries).
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import C0, INF, PR, PT, PV, RANK

@_inline
def _crossing(P, I, edges, k, nc, n, L, g, D, PER, GRAV, PAIRS, NL, WIDE=False):
    """(absolute time, code) of particle k's next wall bounce or cell crossing.

    code = 4 d + 2 [towards +] + [a wall]; (inf, -1) if there is none.
    Along the gravity axis the times come from the stable quadratic forms
    of physics.md section 10. With neighbour lists (NL) there are no cell
    crossings: only the walls. WIDE (size classes): a particle may be wider than a cell, its
    wall plane inside a cell other than the box's first or last.
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
                if WIDE:
                    # its wall plane lies in the cell its centre reaches last
                    lo_wall = lo_wall or edges[c] <= r
                    hi_wall = hi_wall or edges[c + 1] >= L - r
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
            # selects, not branches (the sign of v is a coin toss): the face ahead, the
            # time to it (inf if it has none: v = 0, or no such face in 1D)
            up = v > 0.0
            ahead = has_hi if up else (has_lo and v < 0.0)
            dt = ((hi if up else lo) - x) / v
            dt = dt if ahead else INF
            wall = hi_wall if up else lo_wall
        if dt < 0.0:
            dt = 0.0
        if dt < best:
            best = dt
            code = 4 * d + (2 if up else 0) + (1 if wall else 0)
    return P[k, PT] + best, code


@_inline
def _wrap(P, IM, k, L, D):
    """Particle k's position wrapped into the periodic box [0, L)^D; the box lengths taken
    off are added to its images IM[k] (x + IM L stays the unwrapped position)."""
    for a in range(D):
        if P[k, a] < 0.0 or P[k, a] >= L:
            m = math.floor(P[k, a] / L)
            P[k, a] -= L * m
            if P[k, a] >= L:
                P[k, a] = 0.0
                m += 1.0
            IM[k, a] += int(m)


@_inline
def _count_wrap(I, IM, k, d, up, nc):
    """Particle k crossing the face of its cell along axis d (up: the upper one): if that
    face is the box's, the crossing wraps it (L -> 0 up, 0 -> L down), one image more (up)
    or less in IM[k, d]. Call before the crossing changes its cell coordinate I[k, C0 + d]."""
    c = I[k, C0 + d]
    if up and c == nc - 1:
        IM[k, d] += 1
    elif not up and c == 0:
        IM[k, d] -= 1


@_inline
def _nearest(dx, L):
    """The periodic image of a separation dx nearest to 0 (minimum image)."""
    return dx - L * np.rint(dx / L)


@_inline
def _nearest_near(dx, L, hl):
    """The periodic image of a separation dx nearest to 0, for |dx| < 3 L / 2 (hl = L / 2):
    one shift by L at most (no division)."""
    if dx > hl:
        return dx - L
    if dx < -hl:
        return dx + L
    return dx


@_inline
def _bounce(P, k, d, up, L):
    """Particle k bounces off the wall across axis d (the upper one if up): its centre is put
    exactly on the wall plane, its velocity along d reflected."""
    P[k, d] = (L - P[k, PR]) if up else P[k, PR]
    P[k, PV + d] = -P[k, PV + d]
