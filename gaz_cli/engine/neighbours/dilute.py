"""Dilute gases in a box with walls: every particle scans all the others, no cells.

When the mean free path is comparable to the box (the README example: 1000 argon atoms at
1 atm, mean free path 80 nm in a 34 nm box), cells a few diameters wide cost about ten
crossing events per physical event, each a trip through the calendar. Here there are no
cells and no crossings: a particle's next events are its next wall bounce and its two
earliest collisions before it, found by scanning every particle in two passes:

1. a rejection pass over a structure-of-arrays copy ``XS`` of the rows (positions,
   velocities, time stamps, radii: rows 0-7 of ``XS``, particle m in column m),
   contiguous and free of branches, so that LLVM vectorises it: a pair is kept only if it
   approaches (b = dx.dv < 0), its closest approach on straight lines is within contact
   (|dx x dv|^2 = |dx|^2 |dv|^2 - b^2 <= sigma^2 |dv|^2) and it can touch before the
   particle's next wall bounce (|dx|^2 - sigma^2 + 2 b H <= 0, H the time to it; see
   :func:`.interactions._pair_time_within`). Both bounds get a relative margin far above
   their round-off, so the pass only ever keeps too many; its verdict goes to row 8 of
   ``XS`` (0: kept, inf: not);
2. the exact pair time (:func:`.interactions._pair_time`, from the rows themselves, as
   every other scan) of the few pairs kept, merged into the two earliest.

The scan is full at every event (no partial scan: there are no crossings), so its second
prediction is sure; predictions later than the next wall bounce are dropped, as the
particle scans again at that bounce. ``XS`` mirrors a particle's row whenever an event
changes it (:func:`_mirror`, called by the loop after each event for its particles) and
all rows when the first predictions are made (:func:`_mirror_all`).

Chosen by :func:`.sizing.use_dilute_scan` (a cost model of both searches); scenes with
gravity or a periodic box keep cells.
"""

from __future__ import annotations

from gaz_cli.engine.dynamics import _relative_at
from gaz_cli.engine.interactions import _pair_time
from gaz_cli.engine.intrinsics import _fma, _inline
from gaz_cli.engine.layout import CNT, INF, PART, PART2, PCNT, PCNT2, PR, PV, SURE, TCOL, TCOL2, TX

XS_ROWS = 9
"""Rows of the structure-of-arrays copy: x0 x1 x2 v0 v1 v2 t_stamp radius, then the
rejection pass's verdict."""

KEEP = 8
"""The row of ``XS`` holding the rejection pass's verdict (0.0 kept, inf rejected)."""

REJECT_MARGIN = 1e-9
"""Relative margin of the rejection bounds: their round-off is a few 1e-16 of the largest
term (|dx|^2 |dv|^2, |dx|^2), so the pass keeps every pair the exact root may find."""


@_inline
def _mirror(P, XS, p):
    """Copy particle p's row (positions, velocities, stamp, radius) into column p of XS."""
    for c in range(8):
        XS[c, p] = P[p, c]


@_inline
def _mirror_all(P, XS, n):
    """Copy every particle's row into XS (before the first predictions)."""
    for p in range(n):
        for c in range(8):
            XS[c, p] = P[p, c]


@_inline
def _reject_pass(XS, n, t, xk0, xk1, xk2, vk0, vk1, vk2, rk, horizon):
    """Pass 1: XS[KEEP, m] = 0.0 for every particle m that may touch the particle at x_k,
    v_k (radius rk, at time t) within ``horizon`` s, inf for the others (see the module
    docstring); returns how many are kept. O(n), branch-free: LLVM vectorises it."""
    lo = 1.0 - REJECT_MARGIN
    hi = 1.0 + REJECT_MARGIN
    h2 = 2.0 * horizon
    kept = 0
    for m in range(n):
        # (fused multiply-adds: a quarter fewer operations than products and sums apart)
        dtm = t - XS[6, m]
        dx0 = _fma(XS[3, m], dtm, XS[0, m]) - xk0
        dx1 = _fma(XS[4, m], dtm, XS[1, m]) - xk1
        dx2 = _fma(XS[5, m], dtm, XS[2, m]) - xk2
        dv0 = XS[3, m] - vk0
        dv1 = XS[4, m] - vk1
        dv2 = XS[5, m] - vk2
        b = _fma(dx2, dv2, _fma(dx1, dv1, dx0 * dv0))
        r2 = _fma(dx2, dx2, _fma(dx1, dx1, dx0 * dx0))
        a = _fma(dv2, dv2, _fma(dv1, dv1, dv0 * dv0))
        sg = rk + XS[7, m]
        s2 = sg * sg * hi
        # kept if all three are < 0 (one comparison, no branch): approaching; closest
        # approach |dx|^2 |dv|^2 - b^2 within contact; contact possible within the horizon,
        # |dx|^2 - sigma^2 + 2 b H <= 0 (an infinite horizon and b = 0 give NaN, which max
        # passes over: b >= 0 rejects it); each bound widened by REJECT_MARGIN
        miss = _fma(r2 * lo, a, -_fma(b, b, s2 * a))
        late = _fma(b, h2, _fma(r2, lo, -s2))
        keep = max(b, max(miss, late)) < 0.0
        XS[KEEP, m] = 0.0 if keep else INF
        kept += keep
    return kept


@_inline
def _predict_all(P, I, EV, XS, p, t, n, g, PP, D, GRAV):
    """Particle p's two earliest collisions (its row at t) before its next wall bounce
    EV[p, TX], among all particles, written to its predictions (partners' counters now,
    the second sure); returns the pair times computed exactly (the rejection pass's
    survivors)."""
    xk0 = P[p, 0]
    xk1 = P[p, 1]
    xk2 = P[p, 2]
    vk0 = P[p, PV]
    vk1 = P[p, PV + 1]
    vk2 = P[p, PV + 2]
    rk = P[p, PR]
    tx = EV[p, TX]
    kept = _reject_pass(XS, n, t, xk0, xk1, xk2, vk0, vk1, vk2, rk, tx - t)
    best = INF
    bj = -1
    best2 = INF
    bj2 = -1
    exact = 0
    for m in range(n):
        if kept == 0:  # (most scans of a dilute gas keep none: no second pass at all)
            break
        if XS[KEEP, m] == 0.0:
            kept -= 1
            exact += 1
            dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, m, t, xk0, xk1, xk2, vk0, vk1, vk2,
                                                        g, D, GRAV)
            tp = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rk, P[m, PR], PP, D)
            if tp < best2 and tp <= tx:
                if tp < best:
                    best2 = best
                    bj2 = bj
                    best = tp
                    bj = m
                else:
                    best2 = tp
                    bj2 = m
    EV[p, TCOL] = best
    I[p, PART] = bj
    I[p, PCNT] = I[bj, CNT] if bj >= 0 else 0
    EV[p, TCOL2] = best2
    I[p, PART2] = bj2
    I[p, PCNT2] = I[bj2, CNT] if bj2 >= 0 else 0
    I[p, SURE] = 1
    return exact
