"""Contact passes: within one step, the contacts of walls, planes and pairs are listed and
resolved earliest first, a particle taking part in at most one contact a pass; the particles
that moved are the next pass's active set (see :mod:`.loop` for the whole step).
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.step.cells import _bin, _cells_per_axis
from gaz_cli.engines.step.codes import (C_COLLISIONS, C_OVERLAP_MAX, C_OVERLAP_PAIRS, C_OVERLAP_STEPS,
                                       C_PASS_LIMIT, G_CLOSEST, G_FIRST_TIME, _grow_f, _grow_i, _now)
from gaz_cli.engines.step.contacts import _collide, _detect
from gaz_cli.engines.step.walls import _apply_wall, _wall_scan, _walls_sweep
from gaz_cli.numba_config import njit


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
def _contact_passes(t_end, dt, pos, vel, acc, mass, radius, age, tlast, planes, length, g, gamma, e, ew, tc,
                    has_pair, h, hr, max_passes, swept, want_b, want_c, bf, bi, nb, cf, ci, ncoll,
                    counters, virial, overlap, clock_id, tbuf, rmax, nc_max, start, cell_of, order, active, last,
                    support, hold_row, done, speed, cand_i, cand_j, cand_tau, left):
    """The contact passes of one step ending at t_end s (all particles drifted, every one
    active, no wall holding any): repeated until a pass applies nothing or max_passes, then
    the safety net (:func:`.walls._walls_sweep`).

    Returns (passes, wall_time s, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau): the
    event buffers and the candidate arrays may have been reallocated.
    """
    n, dim = pos.shape
    passes = 0
    wall_time = 0.0
    while True:
        passes += 1
        w0 = _now(clock_id, tbuf)
        k = _wall_scan(pos, vel, acc, radius, age, last, active, length, ew, g, h, hr, gamma, planes, 0, cand_i,
                       cand_j,
                       cand_tau)
        if k > cand_i.shape[0]:
            cand_i, cand_j, cand_tau = _grow_candidates(cand_i, cand_j, cand_tau, 0, k)
            k = _wall_scan(pos, vel, acc, radius, age, last, active, length, ew, g, h, hr, gamma, planes, 0,
                           cand_i, cand_j, cand_tau)
        wall_time += _now(clock_id, tbuf) - w0
        vmax = 0.0
        vsum2 = 0.0
        if swept:
            for i in range(n):
                v2 = 0.0
                for d in range(dim):
                    v2 += vel[i, d] * vel[i, d]
                speed[i] = math.sqrt(v2)
                vsum2 += v2
                if speed[i] > vmax:
                    vmax = speed[i]
        # cells as wide as the reach of a particle at twice the rms speed (nearly all of them);
        # the few faster ones search further
        nc = _cells_per_axis(length, 2.0 * rmax + 4.0 * math.sqrt(vsum2 / n) * dt, n, dim)
        if nc > nc_max:
            nc = nc_max
        _bin(pos, length, nc, cell_of, start, order)
        kw = k
        left[0] = 0.0
        left[1] = 1.0
        k = _detect(pos, vel, radius, age, active, passes == 1, speed, vmax, 2.0 * rmax, dt, length, nc,
                    cell_of, start, order, swept, kw, cand_i, cand_j, cand_tau, left, support)
        if k > cand_i.shape[0]:
            cand_i, cand_j, cand_tau = _grow_candidates(cand_i, cand_j, cand_tau, kw, k)
            left[0] = 0.0
            left[1] = 1.0
            k = _detect(pos, vel, radius, age, active, passes == 1, speed, vmax, 2.0 * rmax, dt, length,
                        nc, cell_of, start, order, swept, kw, cand_i, cand_j, cand_tau, left, support)
        if passes == 1 and left[0] > 0.0:
            if counters[C_OVERLAP_STEPS] == 0:
                overlap[G_FIRST_TIME] = t_end
            counters[C_OVERLAP_STEPS] += 1
            counters[C_OVERLAP_PAIRS] += int(left[0])
            if left[0] > counters[C_OVERLAP_MAX]:
                counters[C_OVERLAP_MAX] = int(left[0])
            if left[1] < overlap[G_CLOSEST]:
                overlap[G_CLOSEST] = left[1]
        for i in range(n):
            done[i] = 0
        applied = 0
        if k > 0:
            idx = np.argsort(-cand_tau[:k], kind="mergesort")
            for m in range(k):
                i = cand_i[idx[m]]
                j = cand_j[idx[m]]
                if done[i] or (j >= 0 and done[j]):
                    continue
                tau = cand_tau[idx[m]]
                if j < 0:
                    w0 = _now(clock_id, tbuf)
                    bf, bi, nb = _apply_wall(i, -1 - j, pos, vel, acc, radius, age, last, planes, length, ew, g, h,
                                             hr, gamma, t_end, want_b, bf, bi, nb, counters, support, hold_row)
                    done[i] = 1
                    applied += 1
                    wall_time += _now(clock_id, tbuf) - w0
                    continue
                impulse = _collide(pos, vel, mass, radius, age, tlast, i, j, tau, t_end, e, tc, acc, has_pair,
                                   g, gamma, h, support, hold_row, bf)
                if impulse <= 0.0:
                    continue
                done[i] = 1
                done[j] = 1
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
        for i in range(n):
            active[i] = done[i]
        if passes >= max_passes:
            counters[C_PASS_LIMIT] += 1
            w0 = _now(clock_id, tbuf)
            bf, bi, nb = _walls_sweep(pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma, t_end,
                                      want_b, bf, bi, nb, counters, support, hold_row)
            wall_time += _now(clock_id, tbuf) - w0
            break
    return passes, wall_time, bf, bi, nb, cf, ci, ncoll, cand_i, cand_j, cand_tau
