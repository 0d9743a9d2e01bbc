"""Contact passes: within one step, the contacts of walls, planes and pairs are listed and
resolved earliest first, a particle taking part in at most one contact a pass; the particles
that moved are the next pass's active set (see :mod:`.loop` for the whole step).

The first pass examines every particle, one patch a thread (:func:`_first_scan`: each
patch's wall checks and contact searches write its own candidate buffer, reading the
neighbouring patches' border cells for the pairs across its borders). A later pass examines
only the particles the pass before moved (a list), serially: a few per cent of them.

The order of resolution is physics, not layout: candidates are sorted by contact time,
earliest first, ties by particle identity (walls before pairs, then the ``ident`` of the
first particle, then of the second: :func:`_before`), so the same seed gives the same rows
whatever the patches and threads.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from gaz_cli.engines.step.codes import (C_COLLISIONS, C_OVERLAP_MAX, C_OVERLAP_PAIRS, C_OVERLAP_STEPS,
                                        C_PASS_LIMIT, G_CLOSEST, G_FIRST_TIME, _grow_f, _grow_i, _now)
from gaz_cli.engines.step.contacts import _resolve_contact, _search_cells, _search_rows
from gaz_cli.engines.step.patches import _patch_cells
from gaz_cli.engines.step.ranks import _owned, _share
from gaz_cli.engines.step.walls import _apply_wall, _wall_rows, _walls_sweep
from gaz_cli.numba_config import njit, pnjit


@njit
def _grow_candidates(cand_i, cand_j, cand_tau, keep, need):
    """Candidate arrays of at least ``need`` rows keeping the first ``keep``."""
    size = max(need, 2 * cand_i.shape[0])
    ni = np.empty(size, np.int64)
    nj = np.empty(size, np.int64)
    nt = np.empty(size, np.float64)
    ni[:keep] = cand_i[:keep]
    nj[:keep] = cand_j[:keep]
    nt[:keep] = cand_tau[:keep]
    return ni, nj, nt


@njit
def _before(a, b, cand_i, cand_j, cand_tau, ident):
    """True when candidate a is resolved before candidate b: the earlier contact (larger time
    back tau), then a wall (j < 0) before a pair, then the lower ident of i, then of j (a
    total order: a pair is listed once, a particle meets at most one wall a pass)."""
    if cand_tau[a] != cand_tau[b]:
        return cand_tau[a] > cand_tau[b]
    wa = cand_j[a] < 0
    wb = cand_j[b] < 0
    if wa != wb:
        return wa
    ia = ident[cand_i[a]]
    ib = ident[cand_i[b]]
    if ia != ib:
        return ia < ib
    if wa:
        return cand_j[a] > cand_j[b]
    return ident[cand_j[a]] < ident[cand_j[b]]


@njit
def _sort_candidates(k, cand_i, cand_j, cand_tau, ident):
    """The order (k,) in which the k candidates are resolved (:func:`_before`): a merge sort."""
    idx = np.arange(k)
    tmp = np.empty(k, np.int64)
    width = 1
    while width < k:
        for lo in range(0, k, 2 * width):
            mid = min(lo + width, k)
            hi = min(lo + 2 * width, k)
            a = lo
            b = mid
            o = lo
            while a < mid and b < hi:
                if _before(idx[b], idx[a], cand_i, cand_j, cand_tau, ident):
                    tmp[o] = idx[b]
                    b += 1
                else:
                    tmp[o] = idx[a]
                    a += 1
                o += 1
            while a < mid:
                tmp[o] = idx[a]
                a += 1
                o += 1
            while b < hi:
                tmp[o] = idx[b]
                b += 1
                o += 1
        idx, tmp = tmp, idx
        width *= 2
    return idx


@njit
def _scan_patch(p, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed, sigma_max, dt, nc,
                cstart, cend, act, tick, last, support, ci, cj, ct, k, left, walls):
    """The first pass's candidates of patch p's particles (all active): with ``walls`` its wall
    checks, else its pair searches, into its own buffers ci, cj, ct from row k; returns the
    new count (rows beyond the buffers' size: counted, not written)."""
    pos, vel, radius, age, ident, count = L[0], L[1], L[4], L[5], L[7], L[8]
    dim = pos.shape[1]
    lo = p * cap
    hi = lo + count[p]
    if walls:
        return _wall_rows(np.empty(0, np.int64), lo, hi, pos, vel, acc, radius, age, last, length, ew, g, h, hr,
                          gamma, planes, still, k, ci, cj, ct)
    if not swept and length / nc >= sigma_max:  # by pairs of cells, each pair once
        lo1, hi1, lo2, hi2 = _patch_cells(p, p1, p2, nc, dim)
        return _search_cells(lo1, hi1, lo2, hi2, pos, vel, radius, age, ident, sigma_max, nc, cstart, cend, k, ci,
                             cj, ct, left, support)
    return _search_rows(np.empty(0, np.int64), lo, hi, pos, vel, radius, age, act, tick, ident, True, speed, 0.0,
                        sigma_max, 0.0, dt, length, nc, cstart, cend, swept, k, ci, cj, ct, left, support)


@pnjit
def _first_scan(npatch, lo, hi, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed,
                sigma_max, dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk, pleft, walls):
    """:func:`_scan_patch` for patches lo to hi - 1 (all of them but in an MPI run:
    :func:`.ranks._owned`), one a thread: patch p's candidates go to rows p ccap... of pci,
    pcj, pct (ccap = their rows / npatch) after the pk[p] already there (pk[p] = 0 and
    pleft[p] = (0, 1) first with ``walls``), its overlap tally to pleft[p]."""
    ccap = pci.shape[0] // npatch
    if hi - lo == 1:  # no parallel region (its threads' wake-up costs more than one patch's work)
        _first_scan_patch(lo, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed,
                          sigma_max, dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk, pleft, walls,
                          ccap)
        return
    for m in prange(hi - lo):
        _first_scan_patch(lo + m, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed,
                          sigma_max, dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk, pleft, walls,
                          ccap)


@njit
def _first_scan_patch(p, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed, sigma_max,
                      dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk, pleft, walls, ccap):
    """Patch p's part of :func:`_first_scan`."""
    if walls:
        pk[p] = 0
        pleft[p, 0] = 0.0
        pleft[p, 1] = 1.0
    lo = p * ccap
    pk[p] = _scan_patch(p, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept, speed, sigma_max,
                        dt, nc, cstart, cend, act, tick, last, support, pci[lo:lo + ccap], pcj[lo:lo + ccap],
                        pct[lo:lo + ccap], pk[p], pleft[p], walls)


@pnjit
def _speeds(npatch, cap, vel, count, speed, pmax):
    """|v| of every particle (speed), the largest of each patch (pmax), one patch a thread."""
    if npatch == 1:
        _speeds_patch(0, cap, vel, count, speed, pmax)
        return
    for p in prange(npatch):
        _speeds_patch(p, cap, vel, count, speed, pmax)


@njit
def _speeds_patch(p, cap, vel, count, speed, pmax):
    """Patch p's part of :func:`_speeds`."""
    dim = vel.shape[1]
    vmax = 0.0
    for i in range(p * cap, p * cap + count[p]):
        v2 = 0.0
        for d in range(dim):
            v2 += vel[i, d] * vel[i, d]
        speed[i] = math.sqrt(v2)
        if speed[i] > vmax:
            vmax = speed[i]
    pmax[p] = vmax


@njit
def _contact_passes(t_end, dt, L, cap, p1, p2, acc, planes, length, g, gamma, e, ew, tc, has_pair, h, hr,
                    max_passes, swept, want_b, want_c, bf, bi, nb, cf, ci, ncoll, counters, virial, overlap,
                    clock_id, tbuf, sigma_max, nc, cstart, cend, xb, act, done, tick, last, support, hold_row,
                    speed, pmax, touched, cand_i, cand_j, cand_tau, pci, pcj, pct, pk, pleft, byident,
                    rank, nranks):
    """The contact passes of one step ending at t_end s (all particles drifted, binned, every
    one active, no wall holding any): repeated until a pass applies nothing or max_passes,
    then the safety net (:func:`.walls._walls_sweep`, the particles in ``ident`` order).

    ``act``, ``done`` (rows,) int64 stamps: a particle is active in a pass, or done in it,
    when its stamp equals the pass's tick (a counter that only grows, so nothing is ever
    cleared); ``touched`` (rows,) scratch for the list of the particles a pass moved.

    ``rank``, ``nranks``: this process and the processes of an MPI run (0, 1 otherwise): the
    first pass scans this rank's patches only (:func:`.ranks._owned`) and shares the
    candidates (:func:`.ranks._share`); every rank then resolves all of them, the same way.

    Returns (passes, wall_time s, tick, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau,
    pci, pcj, pct): buffers may have been reallocated.
    """
    pos, vel, mass, radius, age, tlast, ident, count = L[0], L[1], L[3], L[4], L[5], L[6], L[7], L[8]
    npatch = p1 * p2
    lo, hi = _owned(npatch, rank, nranks)
    still = g == 0.0 and not has_pair
    full = not still  # gravity or attraction: walls may hold particles and pass their load on
    passes = 0
    wall_time = 0.0
    ntouched = 0
    slack = 0.0
    vmax = 0.0
    while True:
        passes += 1
        tick += 1
        if passes == 1:
            # every particle, one patch a thread
            if swept:
                _speeds(npatch, cap, vel, count, speed, pmax)
                for p in range(npatch):
                    vmax = max(vmax, pmax[p])
            for p in range(npatch):
                for i in range(p * cap, p * cap + count[p]):
                    act[i] = tick
            w0 = _now(clock_id, tbuf)
            while True:
                _first_scan(npatch, lo, hi, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept,
                            speed, sigma_max, dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk,
                            pleft, True)
                w1 = _now(clock_id, tbuf)
                wall_time += w1 - w0
                _first_scan(npatch, lo, hi, p1, p2, cap, L, acc, planes, length, ew, g, h, hr, gamma, still, swept,
                            speed, sigma_max, dt, nc, cstart, cend, act, tick, last, support, pci, pcj, pct, pk,
                            pleft, False)
                if nranks > 1:  # every rank gets every patch's candidates (an MPI run: .ranks)
                    _share(pci, pcj, pct, pk, pleft)
                w0 = _now(clock_id, tbuf)
                need = 0
                for p in range(npatch):
                    need = max(need, pk[p])
                if need <= pci.shape[0] // npatch:
                    break
                pci, pcj, pct = _grow_candidates(pci, pcj, pct, 0, 2 * need * npatch)
            ccap = pci.shape[0] // npatch
            k = 0
            for p in range(npatch):
                k += pk[p]
            if k > cand_i.shape[0]:
                cand_i, cand_j, cand_tau = _grow_candidates(cand_i, cand_j, cand_tau, 0, k)
            k = 0
            nleft = 0.0
            closest = 1.0
            for p in range(npatch):
                for r in range(p * ccap, p * ccap + pk[p]):
                    cand_i[k] = pci[r]
                    cand_j[k] = pcj[r]
                    cand_tau[k] = pct[r]
                    k += 1
                nleft += pleft[p, 0]
                closest = min(closest, pleft[p, 1])
            if nleft > 0.0:
                if counters[C_OVERLAP_STEPS] == 0:
                    overlap[G_FIRST_TIME] = t_end
                counters[C_OVERLAP_STEPS] += 1
                counters[C_OVERLAP_PAIRS] += int(nleft)
                if nleft > counters[C_OVERLAP_MAX]:
                    counters[C_OVERLAP_MAX] = int(nleft)
                if closest < overlap[G_CLOSEST]:
                    overlap[G_CLOSEST] = closest
        else:
            # the particles the last pass moved, serially
            if full:  # a held particle's load moves its holders too: measure everyone
                slack = 0.0
                for p in range(npatch):
                    for i in range(p * cap, p * cap + count[p]):
                        for d in range(pos.shape[1]):
                            slack = max(slack, abs(pos[i, d] - xb[i, d]))
                if swept:
                    _speeds(npatch, cap, vel, count, speed, pmax)
                    vmax = 0.0
                    for p in range(npatch):
                        vmax = max(vmax, pmax[p])
            else:
                for m in range(ntouched):
                    i = touched[m]
                    for d in range(pos.shape[1]):
                        slack = max(slack, abs(pos[i, d] - xb[i, d]))
                    if swept:
                        v2 = 0.0
                        for d in range(pos.shape[1]):
                            v2 += vel[i, d] * vel[i, d]
                        speed[i] = math.sqrt(v2)
                        vmax = max(vmax, speed[i])
            for m in range(ntouched):
                act[touched[m]] = tick
            w0 = _now(clock_id, tbuf)
            while True:
                k = _wall_rows(touched, 0, ntouched, pos, vel, acc, radius, age, last, length, ew, g, h, hr, gamma,
                               planes, still, 0, cand_i, cand_j, cand_tau)
                w1 = _now(clock_id, tbuf)
                wall_time += w1 - w0
                w0 = w1
                left = np.zeros(2)
                k = _search_rows(touched, 0, ntouched, pos, vel, radius, age, act, tick, ident, False, speed, vmax,
                                 sigma_max, slack, dt, length, nc, cstart, cend, swept, k, cand_i, cand_j, cand_tau,
                                 left, support)
                if k <= cand_i.shape[0]:
                    break
                cand_i, cand_j, cand_tau = _grow_candidates(cand_i, cand_j, cand_tau, 0, k)
        # resolve, earliest first (ties by identity)
        applied = 0
        ntouched = 0
        if k > 0:
            idx = _sort_candidates(k, cand_i, cand_j, cand_tau, ident)
            for m in range(k):
                i = cand_i[idx[m]]
                j = cand_j[idx[m]]
                if done[i] == tick or (j >= 0 and done[j] == tick):
                    continue
                tau = cand_tau[idx[m]]
                if j < 0:
                    w0 = _now(clock_id, tbuf)
                    bf, bi, nb = _apply_wall(i, -1 - j, pos, vel, acc, radius, age, last, planes, length, ew, g, h,
                                             hr, gamma, t_end, want_b, bf, bi, nb, counters, support, hold_row)
                    done[i] = tick
                    touched[ntouched] = i
                    ntouched += 1
                    applied += 1
                    wall_time += _now(clock_id, tbuf) - w0
                    continue
                impulse = _resolve_contact(pos, vel, mass, radius, age, tlast, i, j, tau, t_end, e, tc, acc, has_pair,
                                   g, gamma, h, support, hold_row, bf)
                if impulse <= 0.0:
                    continue
                done[i] = tick
                done[j] = tick
                touched[ntouched] = i
                touched[ntouched + 1] = j
                ntouched += 2
                last[i] = -1
                last[j] = -1
                applied += 1
                counters[C_COLLISIONS] += 1
                virial[0] += impulse * (radius[i] + radius[j])
                if want_c:
                    if ncoll >= cf.shape[0]:
                        cf = _grow_f(cf)
                        ci = _grow_i(ci)
                    cf[ncoll, 0] = t_end - tau
                    cf[ncoll, 1] = impulse
                    ci[ncoll, 0] = i
                    ci[ncoll, 1] = j
                    ncoll += 1
        if applied == 0:
            break
        if passes >= max_passes:
            counters[C_PASS_LIMIT] += 1
            w0 = _now(clock_id, tbuf)
            for p in range(npatch):
                for i in range(p * cap, p * cap + count[p]):
                    byident[ident[i]] = i
            bf, bi, nb = _walls_sweep(byident, pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma,
                                      t_end, want_b, bf, bi, nb, counters, support, hold_row)
            wall_time += _now(clock_id, tbuf) - w0
            break
    return passes, wall_time, tick, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau, pci, pcj, pct
