"""What a particle predicts after an event: its next wall bounce, cell crossing or list
rebuild, its next partner on the line or in its neighbour list, or the second prediction
that takes over a stale first.

(Cell scans predict in :func:`.neighbours.cells._predict_pairs`; every pair time comes
from :func:`.interactions._pair_time`, every wall time from :func:`.boundaries._crossing`.)
"""

from __future__ import annotations

from gaz_cli.engines.event.boundaries import _crossing
from gaz_cli.engines.event.intrinsics import _inline
from gaz_cli.engines.event.layout import (CNT, CODE, INF, NLCODE, PART, PART2, PCNT, PCNT2, RANK, SURE,
                                          TCOL, TCOL2, TX)
from gaz_cli.engines.event.neighbours.line import _scan_1d
from gaz_cli.engines.event.neighbours.lists import _nl_exit, _scan_nl


@_inline
def _take_second(I, EV, k):
    """k's stale first prediction replaced by its second, if that still holds and is sure
    (the partners that changed since predicted theirs with k themselves): what k's scans
    did not keep comes after it, but the one after it is unknown from now on. Whether
    it was taken (else k must look again from now)."""
    j2 = I[k, PART2]
    if j2 >= 0 and I[j2, CNT] == I[k, PCNT2] and I[k, SURE] != 0:
        I[k, SURE] = 0
        EV[k, TCOL] = EV[k, TCOL2]
        I[k, PART] = j2
        I[k, PCNT] = I[k, PCNT2]
        EV[k, TCOL2] = INF
        I[k, PART2] = -1
        return True
    return False


@_inline
def _next_boundary(P, I, EV, XN, edges, p, nc, n, L, h, g, D, PER, GRAV, PAIRS, NL, MIX):
    """Particle p's next wall bounce or cell crossing (or, NL, the rebuild of its list when it
    leaves its sphere of radius h), into EV[p, TX] and its code into I[p, CODE]; MIX: size
    classes (a particle may be wider than a cell)."""
    tx, cd = _crossing(P, I, edges, p, nc, n, L, g, D, PER, GRAV, PAIRS, NL, MIX)
    if NL:
        te = _nl_exit(P, XN, p, h, g, D, GRAV)
        if te < tx:
            tx = te
            cd = NLCODE
    EV[p, TX] = tx
    I[p, CODE] = cd


@_inline
def _next_partner(P, I, EV, NB, NN, order, p, t, n, L, hl, g, nc, PP, D, PER, GRAV, PF):
    """Particle p's earliest collision (its row at t) with its two neighbours on the line
    (1D) or those of its neighbour list, into its first prediction, stamped with the
    partner's counter (PP: the interaction's parameters); returns the pair times computed.

    A list's scan keeps only collisions before p's next rebuild or bounce (EV[p, TX],
    set first): p rescans at that event anyway."""
    if D == 1:
        best, bj = _scan_1d(P, order, p, I[p, RANK], n, t, L, g, PP, PER, GRAV)
        bc = I[bj, CNT] if bj >= 0 else 0
        tests = 2
    else:
        best, bj, bc = _scan_nl(P, I, NB, NN, p, t, L, hl, g, EV[p, TX], -1, nc, PP, D, PER, GRAV,
                                PF)
        best = best if bj >= 0 else INF
        tests = NN[p]
    EV[p, TCOL] = best
    I[p, PART] = bj
    I[p, PCNT] = bc
    return tests
