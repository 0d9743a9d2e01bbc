"""Neighbours in 1D: the order of rods on the line never changes, so the previous and next."""

from __future__ import annotations

from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.interactions import _pair_time
from gaz_cli.engines.event.layout import INF, PR, PT, PV

@_inline
def _scan_1d(P, order, k, rank, n, t, L, g, PP, PER, GRAV):
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
        tp = t + _pair_time(dx, 0.0, 0.0, dv, 0.0, 0.0, P[k, PR], P[m, PR], PP, 1)
        if tp < best:
            best = tp
            bj = m
    return best, bj
