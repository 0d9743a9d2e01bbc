"""Dilute gases in a box with walls: every particle scans all the others, no cells.

When the mean free path is comparable to the box (the README example: 1000 argon atoms at
1 atm, mean free path 80 nm in a 34 nm box), cells a few diameters wide cost about ten
crossing events per physical event, each a trip through the calendar. Here there are no
cells and no crossings: a particle's next events are its next wall bounce and its two
earliest collisions before it, found by scanning every particle in two passes:

1. a rejection pass, in float32, over a structure-of-arrays copy ``XS`` of the rows
   (each particle's position on its line at an epoch t0, its velocity, its radius: rows
   0-6 of ``XS``, particle m in column m), contiguous and free of branches, so that LLVM
   vectorises it 8 lanes wide (AVX2): a pair is kept if three numbers are <= 0: b - beta
   (b = dx.dv < 0: approaching; beta >= 0 the round-off bound of b for a pair within
   reach, so that a pair within reach now, |dx|^2 <= s^2, is kept unless surely receding:
   the exact root never meets a receding pair); |dv|^2 (|dx|^2 - s^2) - b^2 (its closest
   approach on straight lines, |dx x dv|^2 = |dx|^2 |dv|^2 - b^2 <= s^2 |dv|^2, within
   reach); |dx|^2 - s^2 + 2 (b - beta) H (it can reach before the particle's next wall
   bounce, H the time to it; see :func:`.interactions._pair_time_within`); s the contact
   distance widened by the round-off bound below; a pair within reach now and not surely
   receding passes all three. Its verdict goes to row 7 of ``XS`` (<= 0: kept);
2. the exact float64 pair time (:func:`.interactions._pair_time`, from the rows themselves,
   as every other scan) of the few pairs kept, merged into the two earliest. The exact
   root decides; the pass only filters, so the events are those of a float64 pass (the
   same rows, bit for bit, as before the float32 pass).

The scan is full at every event (no partial scan: there are no crossings), so its second
prediction is sure; predictions later than the next wall bounce are dropped, as the
particle scans again at that bounce. ``XS`` mirrors a particle's row whenever an event
changes it (:func:`_mirror`, called by the loop after each event for its particles) and
all rows when the first predictions are made (:func:`_mirror_all`).

**Units and round-off of the float32 pass.** ``XS`` holds the rows in units of the box
(lengths in box edges L, from the box centre: coordinates in [-1/2, 1/2]) and of a time T,
the time the fastest particle of the first predictions takes to cross L (speeds O(1)), the
positions on the lines at an epoch t0 kept within REBASE T of the scan (:func:`_rebase`
rewrites every column, O(n), when t - t0 passes REBASE T: none in the README example's
10 ns): every number of the pass is O(1), whatever the scene's SI magnitudes (no product
under- or overflows; a contact distance below the round-off is widened to it). With
u = 2^-24, the scaled speeds at most V (a running maximum of every speed mirrored), tau =
(t - t0) / T <= REBASE, a particle's position at t0 on its line within 1/2 + REBASE V of
the centre (its last event is at most REBASE after t0, or before t0: then it is on that
line at t0, in the box), a coordinate of particle m at t, x~ + v~ tau~ (one fma), is off
from the float64 one by at most u/2 (1/2 + REBASE V) (x~), u/2 REBASE V (v~), u/2 REBASE
V (tau~) and u/2 (1/2 + 1) (the fma's rounding), u (1 + 1.5 REBASE V) in all; particle
k's by u/4, their difference's rounding u/2: each coordinate of dx by u (2 + 1.5 REBASE
V) (taken as 8 + 2 REBASE V, the bound of the stamped rows this layout replaced), of dv by
4 u V; so on the pass's straight line dx + dv s, for s in [0, H], is within delta =
sqrt(3) u ((8 + 2 REBASE V) + 4 V H) of the float64 one. A pair the exact
root finds in contact within [t, t + H] therefore comes within s + delta on the pass's
line, and the pass's tests, in exact arithmetic on its float32 inputs, keep every such
pair when s is widened by delta. Their evaluation in float32 errs by at most ~10 u of the
sum of their terms' magnitudes; each term is widened by MARGIN32 = 256 u (|dx|^2 down,
s^2 and H up). A horizon so long that delta exceeds DELTA_MAX (a particle nearly at rest;
infinite at rest) keeps every particle. The tests' adversarial cases are in
tests/test_engine_dilute.py (grazing pairs, contacts just inside the horizon, coordinates
at the walls, boxes 10^4 diameters wide, tiny SI radii).

**Why this layout** (the rejection pass is most of the engine's time on the README example;
measurements: docs/explanation/engine_measurements.md#event-engine-dilute-scan): the pass in
float32, 8 lanes; its verdict stored as the max of the tests (a count of the survivors held
LLVM to 4 lanes); the particle itself out of reach during its own pass (within reach of
itself, it made every scan run the exact pass); a pair within reach kept only when not
surely receding (a collision's partner is receding); the positions at the epoch t0 instead
of stamped rows, the radii pre-widened, ``near`` one fma, the third axis left out in 2D;
the survivors looked for eight verdicts at a time, as one bit mask
(:func:`.intrinsics._kept8`, one vector compare) whose set bits are visited
(:func:`.intrinsics._lowest`). Not kept: the pass in chunks of 256 particles, each chunk's
exact roots before the next (the engine slower though the pass kept its 8 lanes); AVX-512
(16 lanes: the pass alone faster, the whole loop not).

Chosen by :func:`.sizing.use_dilute_scan` (a cost model of both searches); scenes with
gravity or a periodic box keep cells.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _earliest_two, _pair_time
from gaz_cli.engines.event.intrinsics import _fma, _inline, _kept8, _lowest
from gaz_cli.engines.event.layout import CNT, INF, PART, PART2, PCNT, PCNT2, PR, PT, PV, SURE, TCOL, TCOL2, TX

XS_ROWS = 8
"""Rows of the float32 structure-of-arrays copy: x0 x1 x2 (the position on the particle's
line at the epoch t0), v0 v1 v2, the radius widened by WIDEN, in the units of XC (see the
module docstring), then the rejection pass's verdict."""

RAD = 6
"""The row of ``XS`` holding the radius times WIDEN."""

KEEP = 7
"""The row of ``XS`` holding the rejection pass's verdict (<= 0 kept, > 0 rejected)."""

XC_SIZE = 6
"""The float64 units of XS: t0 (s), the box centre (m), 1 / L (1/m), 1 / T (1/s, T the
time the fastest particle of the first predictions takes to cross L), V^2 (a running
maximum of the scaled squared speeds mirrored since), the largest widened radius mirrored
since (box edges)."""

T0, CENTRE, IL, IT, V2, RMAX = 0, 1, 2, 3, 4, 5

U32 = 2.0 ** -24
"""float32's unit round-off."""

REBASE = 1.0
"""The epoch is moved (t0 = t, every row rewritten) when t - t0 exceeds this many time
units T."""

MARGIN32 = 2.0 ** -16
"""Relative widening of the rejection tests' terms: 256 U32, above the round-off of
evaluating them in float32 (at most ~10 U32 of the sum of their terms' magnitudes)."""

WIDEN = (1.0 + MARGIN32) ** 1.5
"""The radii's widening: a contact distance s = (r_k + r_m) WIDEN + delta sqrt(1 + MARGIN32)
squares to (1 + MARGIN32) ((r_k + r_m) (1 + MARGIN32) + delta)^2."""

FAR = np.float32(1e10)
"""A particle's own x0 in XS during its own pass: |dx|^2 = 1e20 (no float32 overflow)
and 2 |b| H < 1e17 below it (|dv| <= 2 V, V H < 1e6 / (4 U32) by DELTA_MAX): rejected."""

DELTA_MAX = 0.25
"""Above this input error bound (in box edges) the pass keeps every particle (a particle
nearly at rest, whose horizon spans a million box crossings; exact roots for all)."""


@_inline
def _mirror_to(P, XS, XC, p, col):
    """Copy particle p's row into column ``col`` of XS, in the units of XC: its position on
    its line at the epoch t0, its velocity, its widened radius; raise XC's running maxima
    (speed, radius)."""
    c, il, it = XC[CENTRE], XC[IL], XC[IT]
    vs = il / it
    back = XC[T0] - P[p, PT]
    v2 = 0.0
    for d in range(3):
        XS[d, col] = (P[p, d] - c + P[p, PV + d] * back) * il
        v = P[p, PV + d] * vs
        XS[3 + d, col] = v
        v2 += v * v
    r = P[p, PR] * il * WIDEN
    XS[RAD, col] = r
    if v2 > XC[V2]:
        XC[V2] = v2
    if r > XC[RMAX]:
        XC[RMAX] = r


@_inline
def _mirror(P, XS, XC, p):
    """Copy particle p's row into column p of XS (:func:`_mirror_to`)."""
    _mirror_to(P, XS, XC, p, p)


@_inline
def _choose_units(P, XC, n, t, L):
    """XC's units for the rows at time t (box edge L): t0 = t, lengths in L from the box
    centre, times in the time the fastest particle takes to cross L."""
    vmax2 = 0.0
    for p in range(n):
        vmax2 = max(vmax2, P[p, PV] ** 2 + P[p, PV + 1] ** 2 + P[p, PV + 2] ** 2)
    XC[T0] = t
    XC[CENTRE] = 0.5 * L
    XC[IL] = 1.0 / L
    # (a gas at rest: any unit, its scaled speeds are 0)
    XC[IT] = math.sqrt(vmax2) / L if vmax2 > 0.0 else 1.0 / L
    XC[V2] = 1.0
    XC[RMAX] = 0.0


@_inline
def _mirror_all(P, XS, XC, n, t, L):
    """Choose XC's units for the rows at time t (box edge L) and copy every row into XS
    (before the first predictions)."""
    _choose_units(P, XC, n, t, L)
    for p in range(n):
        _mirror(P, XS, XC, p)


@_inline
def _rebase(P, XS, XC, n, t):
    """The epoch moved to t0 = t: every particle's position on its line at t (keeps
    t - t0 <= REBASE units: the round-off of the scaled positions and times stays that of
    O(1) numbers)."""
    XC[T0] = t
    for m in range(n):
        _mirror(P, XS, XC, m)


@_inline
def _reject_pass(XS, n, tau, xk0, xk1, xk2, vk0, vk1, vk2, rk, h2, thr, D):
    """Pass 1, in float32: XS[KEEP, m] <= 0 for every particle m that may touch the
    particle at x_k, v_k (widened radius rk) within the horizon, > 0 for the others (all
    arguments float32, in XC's units, from :func:`_bounds`; the module docstring gives the
    tests and why they keep every pair the exact root finds); returns whether any is kept
    (an or, not a count: an int64 count held LLVM to 4 lanes). O(n), branch-free: LLVM
    vectorises it (8 lanes). In 2D (D = 2) the third axis is left out."""
    zero = np.float32(0.0)
    lo = np.float32(1.0 - MARGIN32)
    kept = False
    for m in range(n):
        dv0 = XS[3, m] - vk0
        dv1 = XS[4, m] - vk1
        dx0 = _fma(XS[3, m], tau, XS[0, m]) - xk0
        dx1 = _fma(XS[4, m], tau, XS[1, m]) - xk1
        b = _fma(dx1, dv1, dx0 * dv0)
        r2 = _fma(dx1, dx1, dx0 * dx0)
        a = _fma(dv1, dv1, dv0 * dv0)
        if D > 2:
            dv2 = XS[5, m] - vk2
            dx2 = _fma(XS[5, m], tau, XS[2, m]) - xk2
            b = _fma(dx2, dv2, b)
            r2 = _fma(dx2, dx2, r2)
            a = _fma(dv2, dv2, a)
        sg = rk + XS[RAD, m]
        near = _fma(r2, lo, -(sg * sg))
        # kept if all three are <= 0: approaching or within b's round-off bound (bt);
        # closest approach on the lines within reach, |dx|^2 |dv|^2 - b^2 <= s^2 |dv|^2;
        # reach possible within the horizon, |dx|^2 - s^2 + 2 b H <= 0. A pair within
        # reach now (near < 0) with bt <= 0 passes all three.
        bt = b - thr
        miss = _fma(a, near, -(b * b))
        late = _fma(bt, h2, near)
        verdict = max(bt, max(miss, late))
        XS[KEEP, m] = verdict
        kept |= verdict <= zero
    return kept


@_inline
def _bounds(P, XC, p, t, tx):
    """The float32 arguments of particle p's pass (its row at t) up to its horizon tx, in
    XC's units: (whether the pass may filter, i.e. its input error delta < DELTA_MAX; tau =
    (t - t0) / T, x_k, v_k, the widened radius r_k WIDEN + delta sqrt(1 + MARGIN32), 2 H
    (1 + MARGIN32) for the horizon H, b's round-off bound for a pair within reach: see
    :func:`_reject_pass`)."""
    c, il, it = XC[CENTRE], XC[IL], XC[IT]
    vs = il / it
    tau = (t - XC[T0]) * it
    horizon = (tx - t) * it
    v = math.sqrt(XC[V2]) * (1.0 + 4.0 * U32)  # (>= every |v| in XS, rounded to float32)
    # the round-off of the pass's inputs dx, dv (module docstring), in box edges
    ex = math.sqrt(3.0) * U32 * (8.0 + 2.0 * REBASE * v)
    ev = math.sqrt(3.0) * U32 * 4.0 * v
    delta = ex + ev * horizon
    rk = P[p, PR] * il * WIDEN + delta * math.sqrt(1.0 + MARGIN32)
    # b's round-off for a pair within reach (|dx| <= s, s at most sg, the largest pair's
    # widened contact distance): |dx| ev + |dv| ex + their product + its evaluation's
    # ~8 U32 |dx| |dv|, |dv| <= 2 v; doubled
    sg = (rk + XC[RMAX]) * (1.0 + 4.0 * U32)
    bv = 2.0 * (ev + 8.0 * U32 * 2.0 * v)
    bx = 2.0 * ex * (2.0 * v + ev + 1.0)
    return (delta < DELTA_MAX, np.float32(tau), np.float32((P[p, 0] - c) * il),
            np.float32((P[p, 1] - c) * il), np.float32((P[p, 2] - c) * il),
            np.float32(P[p, PV] * vs), np.float32(P[p, PV + 1] * vs),
            np.float32(P[p, PV + 2] * vs), np.float32(rk),
            np.float32(2.0 * (1.0 + MARGIN32) * horizon), np.float32(sg * bv + bx))


@_inline
def _keep(P, XS, XC, p, t, tx, n, D):
    """Pass 1 for particle p (its row at t) up to its horizon tx: XS[KEEP] marks every
    particle that may touch it by tx (XS[KEEP] <= 0; the epoch moved first if due);
    returns whether any is marked."""
    if (t - XC[T0]) * XC[IT] > REBASE:
        _rebase(P, XS, XC, n, t)
    ok, tau, xk0, xk1, xk2, vk0, vk1, vk2, rk, h2, thr = _bounds(P, XC, p, t, tx)
    if ok:
        own = XS[0, p]
        XS[0, p] = FAR  # (p itself out of reach: dv = 0 exactly, b = 0, |dx|^2 = FAR^2)
        kept = _reject_pass(XS, n, tau, xk0, xk1, xk2, vk0, vk1, vk2, rk, h2, thr, D)
        XS[0, p] = own
    else:  # (every pair exactly: a particle nearly at rest, or at rest: horizon inf)
        for m in range(n):
            XS[KEEP, m] = 0.0
        kept = True
    return kept


@_inline
def _predict_all(P, I, EV, XS, XC, p, t, n, g, PP, D, GRAV):
    """Particle p's two earliest collisions (its row at t) before its next wall bounce
    EV[p, TX], among all particles, written to its predictions (partners' counters now,
    the second sure); returns the pair times computed exactly (the rejection pass's
    survivors)."""
    tx = EV[p, TX]
    kept = _keep(P, XS, XC, p, t, tx, n, D)
    xk0 = P[p, 0]
    xk1 = P[p, 1]
    xk2 = P[p, 2]
    vk0 = P[p, PV]
    vk1 = P[p, PV + 1]
    vk2 = P[p, PV + 2]
    rk = P[p, PR]
    best = INF
    bj = -1
    best2 = INF
    bj2 = -1
    exact = 0
    m = 0
    top = n if kept else 0  # (most scans of a dilute gas keep none: no pass 2)
    while m < top:
        # eight verdicts at a time (_kept8: a bit for each kept, most groups keep none),
        # the last few one by one
        bits = _kept8(XS, KEEP, m) if m + 8 <= n else (1 << (n - m)) - 1
        while bits != 0:
            q = m + _lowest(bits)
            bits &= bits - 1
            if q == p or XS[KEEP, q] > 0.0:
                continue
            exact += 1
            dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(P, q, t, xk0, xk1, xk2, vk0, vk1, vk2,
                                                        g, D, GRAV)
            tp = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rk, P[q, PR], PP, D)
            if tp < best2 and tp <= tx:
                best, bj, _, best2, bj2, _ = _earliest_two(tp, q, 0, best, bj, 0, best2, bj2, 0)
        m += 8
    EV[p, TCOL] = best
    I[p, PART] = bj
    I[p, PCNT] = I[bj, CNT] if bj >= 0 else 0
    EV[p, TCOL2] = best2
    I[p, PART2] = bj2
    I[p, PCNT2] = I[bj2, CNT] if bj2 >= 0 else 0
    I[p, SURE] = 1
    return exact
