"""The record buffers: one row per wall bounce or collision, in time order, handed to the
recorder by the driver when full (the rows name particles by the caller's numbers)."""

from __future__ import annotations

import math

from gaz_cli.engines.event.intrinsics import _helper, _inline
from gaz_cli.engines.event.layout import PV


@_inline
def _record_bounce(P, k, t, ident, d, up, D, bt, bp, bw, bs, bv, nbb):
    """Row nbb of the bounce buffers: time, particle, signed wall 1..D, speed, |v_d|
    (k's velocity before the bounce)."""
    sp = P[k, PV] * P[k, PV]
    for a in range(1, D):
        sp += P[k, PV + a] * P[k, PV + a]
    bt[nbb] = t
    bp[nbb] = ident
    bw[nbb] = (d + 1) if up else -(d + 1)
    bs[nbb] = math.sqrt(sp)
    bv[nbb] = abs(P[k, PV + d])


@_helper
def _record_collision(t, ident_k, ident_j, impulse, ct, ci, cj, cimp, ncb):
    """Row ncb of the collision buffers: time, the two particles, the impulse's magnitude."""
    ct[ncb] = t
    ci[ncb] = ident_k
    cj[ncb] = ident_j
    cimp[ncb] = impulse
