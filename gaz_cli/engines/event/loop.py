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
  2D/3D cell lists with crossing events, neighbour lists for dense fluids, or, for
  dilute gases in a box with walls, a scan of every particle (no cells).
  Events are ordered by a calendar queue (:mod:`.calendar`); the loop requests the
  next events' rows ahead of use, large systems more (:mod:`.prefetch`), hints only:
  the events are the same with or without them (tested).
* Numerical safety (Bannerman et al., Comput. Part. Mech. 1, 191, 2014): the
  pair time is max(0, c / (-b + sqrt(b^2 - a c))) and only for b < 0, so an
  overlapping pair that approaches collides at once and one that separates
  is left alone; a particle past a wall and moving out bounces at once; a
  wall bounce puts the centre exactly on the wall plane, a crossing exactly
  on the cell face.

The loop composes the modules (docs/architecture.md): :mod:`.calendar` orders the
events, :mod:`.dynamics` moves rows along their paths, :mod:`.interactions` and
:mod:`.boundaries` apply and time the events, :mod:`.neighbours` finds the partners to
scan, :mod:`.predict` writes a particle's next events, :mod:`.records` the buffers' rows,
:mod:`.prefetch` requests memory ahead of use; its scalars are one :data:`.layout.STATE`
record. Every helper is inlined
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

from gaz_cli.engines.event.boundaries import _bounce, _count_wrap, _wrap
from gaz_cli.engines.event.calendar import _heap_remove, _next_bucket, _q_insert, _q_remove
from gaz_cli.engines.event.dynamics import _advance
from gaz_cli.engines.event.interactions import _collide
from gaz_cli.engines.event.intrinsics import _borrow, _inline, _sources_digest
from gaz_cli.engines.event.layout import (BUFFER_FULL, C0, CELL, CELL_FULL, CNT, CODE, DONE, KEY,
                                          NL_FULL, NLCODE, NONE, PART, PAUSE, PCNT, QB, SLOT, TCOL,
                                          TX)
from gaz_cli.engines.event.neighbours.cells import (_block_entered, _cell_entered, _cell_of,
                                                    _cross_face, _gather_cells, _predict_pairs)
from gaz_cli.engines.event.neighbours.classes_events import (_cross_face_classes, _gather_classes,
                                                             _room_to_cross)
from gaz_cli.engines.event.neighbours.dilute import _mirror, _mirror_all, _predict_all
from gaz_cli.engines.event.neighbours.lists import _gather_nl, _recentre
from gaz_cli.engines.event.neighbours.wide import _mirror as _wmirror
from gaz_cli.engines.event.neighbours.wide import _mirror_all as _wmirror_all
from gaz_cli.engines.event.neighbours.wide import _moved_out, _path_block, _predict_wide
from gaz_cli.engines.event.predict import _next_boundary, _next_partner, _take_second
from gaz_cli.engines.event.prefetch import (_prefetch_after_event, _prefetch_block, _prefetch_list,
                                            _prefetch_listed, _prefetch_next_events)
from gaz_cli.engines.event.records import _record_bounce, _record_collision
from gaz_cli.numba_config import njit


@_inline
def _gather_rebuild(P, XN, I, IM, cells, NN, NB, SCR, k, t, ainv, nc, L, h, g, D, PER, GRAV,
                    pf):
    """Before a list rebuild changes anything: k moved to t (and wrapped, counted in IM), its
    cell, and its new neighbours gathered into SCR. Returns (their number, or -1 if a list is
    full; the cell, or -1 if it is full; the cell's coordinates)."""
    _advance(P, k, t, g, D, GRAV)
    if PER:
        _wrap(P, IM, k, L, D)
    nn0, nn1, nn2, newcell = _cell_of(P, k, ainv, nc, D)
    if newcell != I[k, CELL] and cells[newcell, 0] >= cells.shape[1] - 1:
        return 0, -1, nn0, nn1, nn2
    x2 = P[k, 2] if D > 2 else 0.0
    if pf:
        # k leaves the lists of its old neighbours: their rows
        for s in range(NN[k]):
            _prefetch_list(NN, NB, NB[k, s])
    ng = _gather_nl(P, XN, cells, NN, SCR, k, P[k, 0], P[k, 1], x2, nn0, nn1, nn2, nc, L, h,
                    D, PER, pf)
    if pf and ng > 0:
        # and joins those of its new ones
        for s in range(ng):
            _prefetch_list(NN, NB, SCR[s])
    return ng, newcell, nn0, nn1, nn2


@functools.lru_cache(maxsize=None)
def build(D: int, PER: bool, GRAV: bool, PAIRS: bool, NL: bool, IMG: bool = False,
          MIX: bool = False, DIL: bool = False, WIDE: bool = False):
    """The kernels for one kind of scene; the flags are compile-time constants.

    D dimension; PER periodic box (else hard walls); GRAV uniform gravity
    along axis D-1; PAIRS some radius > 0; NL neighbour lists (2D/3D,
    PAIRS) instead of cell-crossing events; IMG a periodic box of fewer than
    four cells an axis, or with MIX of fewer than four coarse cells (cell scans carry each cell's
    image shift instead of taking the nearest image); MIX cells per size class (:mod:`.neighbours.classes`:
    the coarse table ``T.CL`` beside the fine one, the counts ``T.CV``); DIL a dilute gas
    in a box with walls, no gravity: every particle scans all the others
    (:mod:`.neighbours.dilute`, one cell, no crossings); WIDE a dilute gas without gravity
    in wide cells whose blocks that pass scans (:mod:`.neighbours.wide`; walls or periodic,
    at least 3 cells an axis). The restitution is a run-time
    value: its branch sits in the collision rule, off the search paths.
    Returns a namespace holding ``loop``.
    """
    NL = bool(NL and PAIRS and D > 1)
    DIL = bool(DIL and PAIRS and D > 1 and not NL and not PER and not GRAV)
    CELLS = bool(PAIRS and D > 1 and not NL and not DIL)  # cell lists with crossing events
    WIDE = bool(WIDE and CELLS and not GRAV)
    IMG = bool(IMG and PER and PAIRS and D > 1 and not NL and not WIDE)
    MIX = bool(MIX and CELLS and not WIDE)
    SOURCES = _sources_digest()

    @njit
    def loop(T, S, PP, t_stop, max_events):
        """Process events in time order up to t_stop (keys <= t_stop); T the arrays
        (:class:`.layout.Tables`), S the loop's state (a :data:`.layout.STATE` record), PP
        the interaction's parameters (:func:`.interactions.pair_params`).

        With max_events < 0 it only makes the first predictions of every particle at time
        t_stop (rows all stamped t_stop), for the caller to build the calendar from
        EV[:, KEY]. Returns DONE, BUFFER_FULL (flush the records and call again),
        CELL_FULL / NL_FULL (grow the cells / lists and call again) or PAUSE (after
        max_events, for the caller to retune the calendar). A status other than DONE is
        returned before the pending event changes anything (a list rebuild may have moved
        its particle along its own path first, which the event, taken again, does not
        notice). Records name the particles by ID[k], the caller's numbering.
        """
        if SOURCES < 0:  # never (the digest is >= 0): keys Numba's cache on every module
            return DONE
        P, M, TL, XN = _borrow(T.P), _borrow(T.M), _borrow(T.TL), _borrow(T.XN)
        I, EV, Q = _borrow(T.I), _borrow(T.EV), _borrow(T.Q)
        HK, HI, BH = _borrow(T.HK), _borrow(T.HI), _borrow(T.BH)
        cells, GB, GS, XS = _borrow(T.cells), _borrow(T.GB), _borrow(T.GS), _borrow(T.XS)
        XC, XB = _borrow(T.XC), _borrow(T.XB)
        NB, NN, SCR = _borrow(T.NB), _borrow(T.NN), _borrow(T.SCR)
        order, edges, ID = _borrow(T.order), _borrow(T.edges), _borrow(T.ID)
        bt, bp, bw, bs, bv = _borrow(T.bt), _borrow(T.bp), _borrow(T.bw), _borrow(T.bs), _borrow(T.bv)
        ct, ci, cj, cimp = _borrow(T.ct), _borrow(T.ci), _borrow(T.cj), _borrow(T.cimp)
        CL, CV, IM = _borrow(T.CL), _borrow(T.CV), _borrow(T.IM)
        st = S[0]
        n = P.shape[0]
        pf = st.pf != 0  # large systems: prefetch, and gather a collision's scans first
        GROOM = GB.shape[0] // 2  # where j's gather goes in GB when both are gathered first
        cur, hsize, ohead, nbk, nc = st.cur, st.hsize, st.ohead, st.nbk, st.nc
        cap = cells.shape[1] - 1
        bufcap, recb, recc, nbb, ncb = st.bufcap, st.recb != 0, st.recc != 0, st.nbb, st.ncb
        iw, L, g, h, virial, tnow = st.iw, st.L, st.g, st.h, st.virial, st.tnow
        hl = 0.5 * L
        ainv = nc / L
        tstop_b = t_stop * iw
        ncl, fcl, rint, bcl, rcut = st.ncl, st.fcl, st.rint, st.bcl, st.rcut
        n_coll = n_bounce = n_cross = n_stale = n_steps = n_rebuild = n_second = 0
        n_overlap = 0
        n_pairs = 0  # pair times computed (the work of the scans)
        n_scanned = 0  # particles the dilute scans' rejection pass went through
        done = 0
        predicting = max_events < 0
        pk = 0
        wb = cur  # the calendar bucket whose list the prefetch walk is in (pf)
        pw = -1  # the walk's particle in it (-1: the list is done)
        status = DONE
        while True:
            # who looks for new events after this one, and where: by default k alone, a
            # full scan (cells c + (lo..hi) an axis), a new crossing time
            j = -1
            nres = 1
            full = newcross = rescan = True
            lo0, hi0, lo1, hi1, lo2, hi2 = -1, 1, -1, 1, -1, 1
            xd, xup, moved = 0, False, False  # MIX: the crossing's axis, way, coarse move
            if predicting:
                # first predictions: every particle in turn, from time t_stop
                if pk >= n:
                    break
                if DIL and pk == 0:
                    _mirror_all(P, XS, XC, n, t_stop, L)
                if WIDE and pk == 0:
                    _wmirror_all(P, I, XB, XC, n, t_stop, L)
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
                # room for what the event adds, checked before anything changes
                rebuild = NL and (not is_col) and code == NLCODE
                ng, newcell, nn0, nn1, nn2 = 0, -1, 0, 0, 0
                if NL and rebuild:
                    ng, newcell, nn0, nn1, nn2 = _gather_rebuild(P, XN, I, IM, cells, NN, NB, SCR,
                                                                 k, t, ainv, nc, L, h, g, D, PER,
                                                                 GRAV, pf)
                    if newcell < 0 or ng < 0:
                        status = CELL_FULL if newcell < 0 else NL_FULL
                        break
                if MIX and not is_col and (code & 1) == 0:
                    if not _room_to_cross(P, I, cells, CL, k, code, nc, fcl, ncl, rcut, D):
                        status = CELL_FULL
                        break
                elif CELLS and not is_col and (code & 1) == 0:
                    cell = _cell_entered(I, k, code, nc, D)
                    if cell != I[k, CELL] and cells[cell, 0] >= cap:
                        status = CELL_FULL
                        break
                hsize = _heap_remove(HK, HI, Q, hsize, 0)
                Q[k, QB] = NONE
                done += 1
                # the next events' rows, at any size (hints only; measurements:
                # docs/explanation/engine_measurements.md#event-engine-loop)
                _prefetch_next_events(M, P, I, EV, Q, NN, NB, HI, hsize, NL)
                tnow = t

                # --- stale? apply: what the event changes, then who looks for new events:
                # k alone (stale, wall, crossing, rebuild) or k and j (collision)
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
                        # a collision between k and j at t
                        nres = 2
                        if pf and CELLS:
                            _prefetch_block(cells, I[j, C0], I[j, C0 + 1], I[j, C0 + 2],
                                            -1, 1, -1, 1, -1, 1, nc, D)
                        if pf and NL:
                            _prefetch_listed(P, NB, NN, j)
                        hsize, ohead = _q_remove(Q, HK, HI, BH, j, nbk, hsize, ohead)
                        _advance(P, j, t, g, D, GRAV)
                        hit, jmag, sg, overlap = _collide(P, M, TL, k, j, t, L, PP, D, PER)
                        if hit:
                            n_overlap += overlap
                            virial += jmag * sg
                            I[k, CNT] += 1
                            I[j, CNT] += 1
                            n_coll += 1
                            if recc:
                                _record_collision(t, ID[k], ID[j], jmag, ct, ci, cj, cimp, ncb)
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
                        if PER:
                            _count_wrap(I, IM, k, d, up, nc)  # before the crossing moves it
                        if MIX:
                            moved = _cross_face_classes(P, I, cells, CL, CV, edges, k, d, up,
                                                        nc, fcl, ncl, bcl, rint, L, rcut, D,
                                                        PER)
                            xd, xup = d, up
                        else:
                            old, sl, co = I[k, CELL], I[k, SLOT], cells[I[k, CELL], 0]
                            _cross_face(P, I, cells, edges, k, d, up, nc, L, D)
                            if WIDE and I[k, CELL] != old:
                                _moved_out(XB, cells, old, sl, co)
                        if not WIDE:  # (wide cells scan the cells along k's path anew)
                            lo0, hi0, lo1, hi1, lo2, hi2 = _block_entered(d, up)

            if DIL and not predicting:
                _mirror(P, XS, XC, k)  # what the event changed, for the scans below
                if j >= 0:
                    _mirror(P, XS, XC, j)
            if WIDE and not predicting:
                _wmirror(P, I, XB, XC, k)
                if j >= 0:
                    _wmirror(P, I, XB, XC, j)

            # --- predict and push, in steps: a gather of a side's cells, then the
            # rest for that side. Large systems (pf) gather both sides first (a
            # collision's second gather requests its rows from memory before the
            # first scan waits on its own), small ones gather each just before its
            # scan (faster in cache). One step loop keeps a single copy of each
            # inlined helper (compile time).
            cellscan = CELLS and rescan and not WIDE
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
                    if MIX:
                        ng = _gather_classes(P, I, cells, CL, CV, GB, GS, base, p, full, xd,
                                             xup, moved, lo0, hi0, lo1, hi1, lo2, hi2, nc, ncl,
                                             fcl, bcl, rint, rcut, D, PER, IMG)
                    else:
                        ng = _gather_cells(P, I, cells, GB, GS, base, I[p, C0], I[p, C0 + 1],
                                           I[p, C0 + 2], lo0, hi0, lo1, hi1, lo2, hi2, nc, D,
                                           PER, IMG, pf)
                    if side == 0:
                        ng0 = ng
                    else:
                        ng1 = ng
                    continue
                if newcross:
                    _next_boundary(P, I, EV, XN, edges, p, nc, n, L, h, g, D, PER, GRAV, PAIRS,
                                   NL, MIX)
                if PAIRS and (D == 1 or NL) and rescan:
                    n_pairs += _next_partner(P, I, EV, NB, NN, order, p, t, n, L, hl, g, nc, PP, D,
                                             PER, GRAV, pf)
                if DIL and rescan:
                    n_pairs += _predict_all(P, I, EV, XS, XC, p, t, n, g, PP, D, GRAV)
                    n_scanned += n
                if WIDE and rescan:
                    tx = EV[p, TX]
                    wl0, wh0, wl1, wh1, wl2, wh2 = _path_block(P, I, XC, edges, p, t, tx, D)
                    exact, slots = _predict_wide(P, I, EV, cells, XB, XC, GB, GS, p, t, tx, n,
                                                 nc, L, g, wl0, wh0, wl1, wh1, wl2, wh2, PP, D,
                                                 PER)
                    n_pairs += exact
                    n_scanned += slots
                if cellscan:
                    ng = ng0 if side == 0 else ng1
                    _predict_pairs(P, I, EV, GB, GS, base, ng, p, t, L, g, full, PP, D, PER,
                                   GRAV, IMG)
                    n_pairs += ng
                key = min(EV[p, TCOL], EV[p, TX])
                EV[p, KEY] = key
                if not predicting:
                    hsize, ohead = _q_insert(Q, HK, HI, BH, p, key, cur, nbk, iw, hsize, ohead)
            if pf and not predicting:
                wb, pw = _prefetch_after_event(M, P, I, EV, Q, BH, HI, NN, NB, cells, hsize, cur,
                                               nbk, wb, pw, nc, D, CELLS, NL)

        st.cur, st.hsize, st.ohead, st.nbb, st.ncb = cur, hsize, ohead, nbb, ncb
        st.events += done
        st.coll += n_coll
        st.bounce += n_bounce
        st.cross += n_cross
        st.stale += n_stale
        st.steps += n_steps
        st.rebuild += n_rebuild
        st.second += n_second
        st.overlap += n_overlap
        st.pairs += n_pairs
        st.scanned += n_scanned
        st.virial = virial
        st.tnow = tnow
        return status

    class Kernels:
        """The specialised kernels of one kind of scene."""

    ns = Kernels()
    ns.loop = loop
    ns.flags = (D, PER, GRAV, PAIRS, NL, IMG, MIX, DIL, WIDE)
    return ns
