"""The event loop of the event-driven engine: pop, stale?, apply, predict, push.

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
* Neighbours (:mod:`.neighbours`): the previous and next rods in 1D; in
  2D/3D cell lists with crossing events, or neighbour lists for dense fluids.
  Events are ordered by a calendar queue (:mod:`.calendar`); large systems
  request memory ahead of use (:mod:`.prefetch`), hints only: the events are
  the same with or without them (tested).
* Numerical safety (Bannerman et al., Comput. Part. Mech. 1, 191, 2014): the
  pair time is max(0, c / (-b + sqrt(b^2 - a c))) and only for b < 0, so an
  overlapping pair that approaches collides at once and one that separates
  is left alone; a particle past a wall and moving out bounces at once; a
  wall bounce puts the centre exactly on the wall plane, a crossing exactly
  on the cell face.

The loop composes the modules (docs/architecture.md): :mod:`.calendar` orders the
events, :mod:`.dynamics` moves rows along their paths, :mod:`.interactions` and
:mod:`.boundaries` apply and time the events, :mod:`.neighbours` finds the partners to
scan, :mod:`.prefetch` requests memory ahead of use. Every helper is inlined
(``_inline``, Numba-IR level) or register-only (``_helper``) and takes borrowed arrays
(:func:`.intrinsics._borrow`): Numba's atomic reference counting, paid at every call
taking an array, cost more than the physics when the loop called helpers on owned
arrays. The loop is specialised per kind of scene by :func:`build` (dimension,
boundary, gravity, radii > 0, neighbour lists, tiny periodic boxes are compile-time
constants): a scene without gravity runs no gravity arithmetic and a scene of points
(all radii 0) does no pair search.

Units are whatever the caller uses (SI in gaz); times are absolute.
"""

from __future__ import annotations

import functools
import math

from gaz_cli.engine.boundaries import _bounce, _crossing, _wrap
from gaz_cli.engine.calendar import _heap_remove, _next_bucket, _q_insert, _q_remove
from gaz_cli.engine.dynamics import _advance
from gaz_cli.engine.interactions import _collide
from gaz_cli.engine.intrinsics import _borrow, _inline, _sources_digest
from gaz_cli.engine.layout import (BUFFER_FULL, CELL, CELL_FULL, CNT, CODE, DONE, F_E,
                                   F_G, F_H, F_IW, F_L, F_TC, F_TNOW, F_VIRIAL, INF, KEY,
                                   NL_FULL, NLCODE, NONE, PART, PART2, PAUSE, PCNT, PCNT2, PV, QB,
                                   RANK, S_BOUNCE, S_BUFCAP, S_COLL, S_CROSS, S_CUR, S_EVENTS,
                                   S_HSIZE, S_NBB, S_NBK, S_NC, S_NCB, S_OHEAD, S_OVERLAP,
                                   S_PAIRS, S_PF, S_REBUILD, S_RECB, S_RECC, S_SECOND, S_STALE,
                                   S_STEPS, SURE, TCOL, TCOL2, TX, C0)
from gaz_cli.engine.neighbours.cells import (_cell_entered, _cell_of, _cross_face, _gather_cells,
                                             _predict_pairs)
from gaz_cli.engine.neighbours.line import _scan_1d
from gaz_cli.engine.neighbours.lists import _gather_nl, _nl_exit, _recentre, _scan_nl
from gaz_cli.engine.prefetch import (_prefetch_after_event, _prefetch_block, _prefetch_list,
                                     _prefetch_listed, _prefetch_next_events)
from gaz_cli.numba_config import njit


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
def _record_bounce(P, k, t, ident, d, up, D, bt, bp, bw, bs, bv, nbb):
    """One row of the bounce buffers (time, particle, signed wall 1..D, speed, |v_d|)."""
    sp = P[k, PV] * P[k, PV]
    for a in range(1, D):
        sp += P[k, PV + a] * P[k, PV + a]
    bt[nbb] = t
    bp[nbb] = ident
    bw[nbb] = (d + 1) if up else -(d + 1)
    bs[nbb] = math.sqrt(sp)
    bv[nbb] = abs(P[k, PV + d])


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
    CELLS = bool(PAIRS and D > 1 and not NL)  # cell lists with crossing events
    SOURCES = _sources_digest()

    @njit
    def loop(T, IS, FS, t_stop, max_events):
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
        if SOURCES < 0:  # never (the digest is >= 0): keys Numba's cache on every module
            return DONE
        P = _borrow(T.P)
        M = _borrow(T.M)
        TL = _borrow(T.TL)
        XN = _borrow(T.XN)
        I = _borrow(T.I)
        EV = _borrow(T.EV)
        Q = _borrow(T.Q)
        HK = _borrow(T.HK)
        HI = _borrow(T.HI)
        BH = _borrow(T.BH)
        cells = _borrow(T.cells)
        GB = _borrow(T.GB)
        GS = _borrow(T.GS)
        NB = _borrow(T.NB)
        NN = _borrow(T.NN)
        SCR = _borrow(T.SCR)
        order = _borrow(T.order)
        edges = _borrow(T.edges)
        ID = _borrow(T.ID)
        bt = _borrow(T.bt)
        bp = _borrow(T.bp)
        bw = _borrow(T.bw)
        bs = _borrow(T.bs)
        bv = _borrow(T.bv)
        ct = _borrow(T.ct)
        ci = _borrow(T.ci)
        cj = _borrow(T.cj)
        cimp = _borrow(T.cimp)
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
                # --- pop: the next event is the top of the heap of the current bucket
                if hsize == 0:
                    cur, hsize, ohead, steps = _next_bucket(Q, HK, HI, BH, EV, cur, nbk, iw,
                                                            ohead, tstop_b)
                    n_steps += steps
                if hsize == 0 or HK[0] > t_stop:
                    status = DONE
                    break
                t = HK[0]
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
                rebuild = NL and (not is_col) and code == NLCODE
                newcell = -1
                ng = 0
                nn0 = 0
                nn1 = 0
                nn2 = 0
                if NL and rebuild:
                    _advance(P, k, t, g, D, GRAV)
                    if PER:
                        _wrap(P, k, L, D)
                    nn0, nn1, nn2, newcell = _cell_of(P, k, ainv, nc, D)
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
                if CELLS and not is_col and (code & 1) == 0:
                    cell = _cell_entered(I, k, code, nc, D)
                    if cell != I[k, CELL] and cells[cell, 0] >= cap:
                        status = CELL_FULL
                        break
                hsize = _heap_remove(HK, HI, Q, hsize, 0)
                Q[k, QB] = NONE
                done += 1
                if pf:
                    _prefetch_next_events(M, P, I, EV, Q, NN, NB, HI, hsize, NL)
                tnow = t

                # --- apply: what the event changes, then who must look for new
                # events: k alone (stale, wall, crossing, rebuild) or k and j (collision)
                _advance(P, k, t, g, D, GRAV)
                if NL and rebuild:
                    n_rebuild += 1
                    _recentre(P, XN, I, cells, NB, NN, SCR, k, ng, newcell, nn0, nn1, nn2, D)
                elif is_col:
                    j = I[k, PART]
                    if I[j, CNT] != I[k, PCNT]:
                        # stale: the partner changed course since
                        n_stale += 1
                        newcross = False
                        if _take_second(I, EV, k):
                            n_second += 1
                            rescan = False
                    else:
                        # a real collision between k and j at t
                        nres = 2
                        if pf and CELLS:
                            _prefetch_block(cells, I[j, C0], I[j, C0 + 1], I[j, C0 + 2],
                                            -1, 1, -1, 1, -1, 1, nc, D)
                        if pf and NL:
                            _prefetch_listed(P, NB, NN, j)
                        hsize, ohead = _q_remove(Q, HK, HI, BH, j, nbk, hsize, ohead)
                        _advance(P, j, t, g, D, GRAV)
                        hit, jmag, sg, overlap = _collide(P, M, TL, k, j, t, L, e, tc, inel,
                                                          D, PER)
                        if hit:
                            if overlap:
                                n_overlap += 1
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
                        # a wall bounce
                        if recb:
                            _record_bounce(P, k, t, ID[k], d, up, D, bt, bp, bw, bs, bv, nbb)
                            nbb += 1
                        _bounce(P, k, d, up, L)
                        I[k, CNT] += 1
                        n_bounce += 1
                    elif CELLS:
                        # a cell crossing: then only the cells that just came into view
                        n_cross += 1
                        full = False
                        _cross_face(P, I, cells, edges, k, d, up, nc, L, D)
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

            # --- predict and push, in steps: a gather of a side's cells, then the
            # rest for that side. Large systems (pf) gather both sides first (a
            # collision's second gather requests its rows from memory before the
            # first scan waits on its own), small ones gather each just before its
            # scan (faster in cache). One step loop keeps a single copy of each
            # inlined helper (compile time).
            cellscan = CELLS and rescan
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
                        bc = I[bj, CNT] if bj >= 0 else 0
                        n_pairs += 2
                    else:
                        # only collisions before the next rebuild or bounce count (that rescans)
                        best, bj, bc = _scan_nl(P, I, NB, NN, p, t, L, hl, g, EV[p, TX], -1,
                                                nc, D, PER, GRAV, pf)
                        best = best if bj >= 0 else INF
                        n_pairs += NN[p]
                    EV[p, TCOL] = best
                    I[p, PART] = bj
                    I[p, PCNT] = bc
                if cellscan:
                    ng = ng0 if side == 0 else ng1
                    _predict_pairs(P, I, EV, GB, GS, base, ng, p, t, L, g, full, D, PER, GRAV,
                                   IMG)
                    n_pairs += ng
                key = min(EV[p, TCOL], EV[p, TX])
                EV[p, KEY] = key
                if not predicting:
                    hsize, ohead = _q_insert(Q, HK, HI, BH, p, key, cur, nbk, iw, hsize, ohead)
            if pf and not predicting:
                wb, pw = _prefetch_after_event(M, P, I, EV, Q, BH, HI, NN, NB, cells, hsize, cur,
                                               nbk, wb, pw, nc, D, CELLS, NL)

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
