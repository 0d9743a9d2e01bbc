"""Pairs in contact: the contact time of a pair (straight or, for a held particle, curved
relative path), the cell-list search of the pairs in contact, and the collision rule.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.engines.step.cells import _cell_coord, _cells_per_axis
from gaz_cli.engines.step.codes import OVERLAP_TOL, SPEED_ROUND_OFF
from gaz_cli.engines.step.resting import _pass_on, _release, _rest_on, _wall_takes
from gaz_cli.engines.step.wall_contact import _velocity_at
from gaz_cli.numba_config import njit


@njit
def _contact_tau(pos, vel, i, j, sigma, age_max, swept, support):
    """(tau, c): how far back (s, >= 0) pair (i, j) touched within age_max, or -1 for no contact;
    c = |dr|^2 - sigma^2 at the step end, m^2 (< 0: overlapping).

    See the module docstring for the rule; always the cancellation-free root. When a wall
    holds one of the two (support (N, D + 1), :func:`gaz_cli.engines.step.resting._hold`) their relative path is not straight
    but the parabola dr - dv tau + A tau^2 / 2, A = support_j - support_i: the straight root
    is refined on it (:func:`gaz_cli.engines.step.contacts._held_root`).
    """
    dim = pos.shape[1]
    c = -sigma * sigma
    for d in range(dim):
        dr = pos[j, d] - pos[i, d]
        c += dr * dr
    if c >= 0.0 and not swept:
        return -1.0, c  # apart: no contact under the overlap rule (most pairs a search meets)
    a = 0.0
    b = 0.0
    for d in range(dim):
        dr = pos[j, d] - pos[i, d]
        dv = vel[j, d] - vel[i, d]
        a += dv * dv
        b += dr * dv
    if b < 0.0:
        if c >= 0.0:
            return -1.0, c  # approaching but apart: a future contact
        tau = -c / (math.sqrt(b * b - a * c) - b)
        tau = _held_root(pos, vel, support, i, j, sigma, tau)[0]
        return tau if tau < age_max else age_max, c
    if not swept or a <= 0.0:
        return -1.0, c
    disc = b * b - a * c
    if disc < 0.0:
        return -1.0, c
    tau = _held_root(pos, vel, support, i, j, sigma, (b + math.sqrt(disc)) / a)[0]
    return tau if tau <= age_max else -1.0, c


@njit
def _held_gap(pos, vel, support, i, j, d, tau):
    """Along axis d, for the pair (i, j) of :func:`gaz_cli.engines.step.contacts._held_root`: the relative acceleration of
    the supports, the relative drift velocity, and the separation tau s before the step's end."""
    a_d = support[j, d] - support[i, d]
    dv = vel[j, d] - vel[i, d]
    return a_d, dv, pos[j, d] - pos[i, d] - dv * tau + 0.5 * a_d * tau * tau


@njit
def _held_root(pos, vel, support, i, j, sigma, tau0):
    """(tau, impact): the contact time back (s) of pair (i, j) on its relative path p(tau) = dr -
    dv tau + A tau^2 / 2 (dr, dv at the step's end, A = support_j - support_i, m/s^2: a particle
    held at rest by a wall does not fall along its drift line, its partner does), by Newton's
    method on |p|^2 = sigma^2 from the straight-line root tau0, and True, when the pair hits
    there: entering contact going forward, faster than the support's relative acceleration
    along the line of centres builds up over those tau s (-v_n > |A.n| tau). Otherwise (tau0,
    False): neither is held, Newton found no such root, or the pair merely rests on the held
    one (a ball on a ball on the floor touches it at the step's start at v_n = 0): that
    contact is met on the drift lines, the partner held by the held one (:func:`gaz_cli.engines.step.resting._rest_on`)
    (met on the true path, it is a series of vanishing impacts within the step that the
    passes cannot end: a resting stack sank through itself)."""
    dim = pos.shape[1]
    held = False
    for d in range(dim):
        if support[j, d] != 0.0 or support[i, d] != 0.0:
            held = True
    if not held:
        return tau0, False
    tau = tau0
    for _ in range(30):
        f = -sigma * sigma
        fp = 0.0
        for d in range(dim):
            a_d, dv, p = _held_gap(pos, vel, support, i, j, d, tau)
            f += p * p
            fp += 2.0 * p * (a_d * tau - dv)
        if fp <= 0.0:
            return tau0, False
        step = f / fp
        tau -= step
        if abs(step) <= 1e-10 * abs(tau):  # converging quadratically: the next step is round-off
            if tau < 0.0:
                return tau0, False
            pp = 0.0
            vn = 0.0
            an = 0.0
            for d in range(dim):
                a_d, dv, p = _held_gap(pos, vel, support, i, j, d, tau)
                pp += p * p
                vn += (dv - a_d * tau) * p
                an += a_d * p
            if -vn > abs(an) * tau:  # both scaled by |p|
                return tau, True
            return tau0, False
    return tau0, False


@njit
def _keep_pair(i, j, tau, c, sigma, tally, shrink, left, k, cand_i, cand_j, cand_tau):
    """Pair (i, j) into the candidates' row k when it is in contact (tau >= 0, tau from
    :func:`_contact_tau`, which also gives c = |dr|^2 - sigma^2); a pair not in contact and
    overlapping by more than the tolerance (c < shrink sigma^2) counted in ``left`` (count,
    smallest |dr| / sigma) with ``tally``. Returns the new count (rows beyond the buffers'
    size: counted, not written)."""
    if tau < 0.0:
        if tally and c < shrink * sigma * sigma:
            left[0] += 1.0
            ratio = math.sqrt(c / (sigma * sigma) + 1.0)
            if ratio < left[1]:
                left[1] = ratio
        return k
    if k < cand_i.shape[0]:
        cand_i[k] = i
        cand_j[k] = j
        cand_tau[k] = tau
    return k + 1


@njit
def _search_rows(rows, first, last, pos, vel, radius, age, act, tick, ident, all_active, speed, vmax, sigma_max,
                 slack, dt, length, nc, cstart, cend, swept, k, cand_i, cand_j, cand_tau, left, support):
    """Write the pairs in contact with the active particles i = rows[first:last] (rows of the
    arrays first to last when ``rows`` is empty) from row k; returns the new count. (One call
    for many particles: a Numba call passing arrays costs reference counts, tens of ns.)

    ``act`` (rows,) int64: the particles whose stamp equals ``tick`` are active in this pass.

    The particles are in cell order (:mod:`.patches`): those of global cell g are the rows
    cstart[g] to cend[g], binned where they were ``slack`` m (largest move since, along an
    axis) ago. With ``all_active`` (a step's first pass) also tallies in ``left`` (2,) the
    pairs the contact rule leaves alone although closer than (1 - OVERLAP_TOL) sigma
    (overlapping and separating: a contact missed in this step or before): left[0] their
    number, left[1] the smallest |dr| / sigma among them.

    Each pair is reported once, by the same member whatever the layout; rows beyond the
    arrays' size are counted, not written (the caller grows the arrays and searches again).
    Search radius around i (m), plus the slack, over the cells it covers:

    * overlap detection: sigma_max (a pair of two active particles is examined from the
      lower ``ident``);
    * swept detection: a pair can have touched during the step only if
      |dr| <= sigma + (|v_i| + |v_j|) dt. When every particle is active
      (first pass) each pair is examined from its faster member (ties: the lower ident),
      within sigma_max + 2 |v_i| dt; otherwise within sigma_max + (|v_i| + vmax) dt,
      a pair of two active particles still from the faster. So only the fast
      particles search far. ``speed`` |v| m/s, ``vmax`` at least its maximum.
    ``support`` (rows, D + 1) m/s^2: the push of the wall holding each particle at rest (0:
    free), for the contacts of a held particle (:func:`_contact_tau`).
    """
    dim = pos.shape[1]
    side = length / nc
    shrink = (1.0 - OVERLAP_TOL) * (1.0 - OVERLAP_TOL) - 1.0
    for m in range(first, last):
        i = rows[m] if rows.size > 0 else m
        if swept:
            if all_active:
                rho = sigma_max + 2.0 * speed[i] * dt
            else:
                rho = sigma_max + (speed[i] + vmax) * dt
        else:
            rho = sigma_max
        m = int(math.ceil((rho + slack) * 1.000001 / side))
        if m < 1:
            m = 1
        c0 = _cell_coord(pos[i, 0], length, nc)
        c1 = _cell_coord(pos[i, 1], length, nc) if dim > 1 else 0
        c2 = _cell_coord(pos[i, 2], length, nc) if dim > 2 else 0
        m1 = m if dim > 1 else 0
        m2 = m if dim > 2 else 0
        lo0 = c0 - m if c0 - m > 0 else 0
        hi0 = c0 + m if c0 + m < nc else nc - 1
        idi = ident[i]
        for k2 in range(max(c2 - m2, 0), min(c2 + m2, nc - 1) + 1):
            for k1 in range(max(c1 - m1, 0), min(c1 + m1, nc - 1) + 1):
                # the cells along axis 0 are consecutive rows of one patch: one range
                row = (k2 * nc + k1) * nc
                for j in range(cstart[row + lo0], cend[row + hi0]):
                    if j == i:
                        continue
                    if act[j] == tick:  # j active too: the pair is examined from one of the two
                        if swept:
                            if speed[j] > speed[i] or (speed[j] == speed[i] and ident[j] < idi):
                                continue
                        elif ident[j] < idi:
                            continue
                    sigma = radius[i] + radius[j]
                    if not swept:  # apart: no contact under the overlap rule (most pairs met; the
                        c = -sigma * sigma  # same sum as _contact_tau's)
                        for d in range(dim):
                            dr = pos[j, d] - pos[i, d]
                            c += dr * dr
                        if c >= 0.0:
                            continue
                    amax = age[i] if age[i] < age[j] else age[j]
                    tau, c = _contact_tau(pos, vel, i, j, sigma, amax, swept, support)
                    k = _keep_pair(i, j, tau, c, sigma, all_active, shrink, left, k, cand_i, cand_j, cand_tau)
    return k


@njit
def _speed_round_off(vel, i, j):
    """The round-off of the relative velocity of particles i and j, m/s (SPEED_ROUND_OFF)."""
    si = 0.0
    sj = 0.0
    for d in range(vel.shape[1]):
        si += vel[i, d] * vel[i, d]
        sj += vel[j, d] * vel[j, d]
    return SPEED_ROUND_OFF * (math.sqrt(si) + math.sqrt(sj))


@njit
def _resolve_contact(pos, vel, mass, radius, age, tlast, i, j, tau, t_end, e, tc, acc, has_pair, g, gamma, h, support,
             hold_row, bf):
    """Take pair (i, j) back by tau s, change its velocities along the line of centres, move it forward.

    Restitution e, or 1 under the TC model when either partner collided less
    than tc s before. Returns the impulse |J| (kg m/s), 0 if the pair does
    not approach at contact (nothing done).

    The impulse is that of the pair's velocities at the contact, not of the
    drift velocities (those of the step's middle, tau - h s later or
    earlier): under a constant acceleration a (acc, the pair attraction at the
    step's start: uniform gravity drops out of a relative velocity) and
    friction gamma, v(t_mid + s) = v e^{-gamma s} + a (1 - e^{-gamma s}) /
    gamma. With the drift velocities the impulse was off by m |a| |tau - h|,
    an energy error of order dt at each collision of attracting bodies (the
    step's error first order in dt); with these it is of order dt^2. The
    velocity change is added to the drift velocities, so that the closing
    half kick continues from the velocities after the contact (under friction the drift
    velocity changes by e^{gamma s} times the change at the contact).

    A particle a wall holds at rest (support (N, D + 1), :func:`gaz_cli.engines.step.resting._hold`) is there, at rest, at
    the contact, not on its drift line: when its partner hits it (:func:`gaz_cli.engines.step.contacts._held_root`), the line
    of centres and the relative velocity are taken on the true paths (dr - dv tau + A tau^2 / 2
    and dv - A tau, A = support_j - support_i), and when the collision takes it off the wall it
    is released (:func:`gaz_cli.engines.step.resting._release`): it flies freely from the contact. A partner merely resting
    on it is held by it in turn (:func:`gaz_cli.engines.step.resting._rest_on`). When the collision leaves it on the wall (along it, or pushed
    into it: :func:`gaz_cli.engines.step.resting._wall_takes`) the wall takes the normal part of its velocity change and it
    stays held: a ball at rest on a wall costs the wall one contact a step, not one more for
    each collision (the marbles preset's pile on its ramp at t = 2.6 s: 6.0 plane contacts a
    ball and step with every impact released, 3.0 so). A pair approaching no faster than the
    round-off of their velocities (SPEED_ROUND_OFF) is not a collision.
    """
    dim = pos.shape[1]
    nrm = np.empty(dim)
    dist2 = 0.0
    hit = _held_root(pos, vel, support, i, j, radius[i] + radius[j], tau)[1]
    for d in range(dim):
        a_d = support[j, d] - support[i, d] if hit else 0.0
        nrm[d] = (pos[j, d] - vel[j, d] * tau) - (pos[i, d] - vel[i, d] * tau) + 0.5 * a_d * tau * tau
        dist2 += nrm[d] * nrm[d]
    if dist2 <= 0.0:
        return 0.0
    inv = 1.0 / math.sqrt(dist2)
    vn = 0.0
    an = 0.0
    for d in range(dim):
        nrm[d] *= inv
        a_d = support[j, d] - support[i, d] if hit else 0.0
        vn += (vel[j, d] - vel[i, d] - a_d * tau) * nrm[d]
        if has_pair:
            an += (acc[j, d] - acc[i, d]) * nrm[d]
    if vn >= 0.0 or -vn <= _speed_round_off(vel, i, j):
        return 0.0
    if not hit:
        jr = _rest_on(pos, vel, mass, acc, has_pair, g, support, hold_row, bf, i, j, nrm, vn, tau, e)
        if jr > 0.0:
            age[i] = tau
            age[j] = tau
            tlast[i] = t_end - tau
            tlast[j] = t_end - tau
            return jr
    s = h - tau  # contact time - the step's middle, s
    back = 1.0  # a velocity change at the contact is back times that of the drift velocity
    if gamma > 0.0:
        back = math.exp(gamma * s)
    vn_c = _velocity_at(vn, an, s, gamma)
    if vn_c < 0.0:  # else (a graze the attraction turned round): the drift velocities' impulse
        vn = vn_c
    t_c = t_end - tau
    ee = e
    if tc > 0.0 and (t_c - tlast[i] < tc or t_c - tlast[j] < tc):
        ee = 1.0
    mi = mass[i]
    mj = mass[j]
    jn = (1.0 + ee) * mi * mj / (mi + mj) * vn  # < 0
    dvs = np.empty((2, dim))
    for m in range(2):
        k = i if m == 0 else j
        dv = jn / mi if m == 0 else -jn / mj  # velocity change at the contact along nrm, m/s
        for d in range(dim):
            dvs[m, d] = back * dv * nrm[d]
        takes, un = _wall_takes(pos, support, i, j, k, dv, nrm, hit, tau)
        if takes:  # the wall takes the part along its push: k stays on it, held
            a = 0.0
            for d in range(dim):
                a += support[k, d] * support[k, d]
            a = math.sqrt(a)
            for d in range(dim):
                dvs[m, d] -= back * un * support[k, d] / a
            _pass_on(k, mass[k] * un, tau, pos, vel, mass, support, hold_row, bf)
        elif hit:
            for d in range(dim):
                if support[k, d] != 0.0:
                    _release(k, tau, pos, vel, mass, support, hold_row, bf)
                    break
    for m in range(2):
        k = i if m == 0 else j
        for d in range(dim):
            vel[k, d] += dvs[m, d]
            pos[k, d] += dvs[m, d] * tau  # r_c + v' tau = r - v tau + v' tau
    age[i] = tau
    age[j] = tau
    tlast[i] = t_c
    tlast[j] = t_c
    return -jn


@njit
def _overlaps_approaching(pos, vel, radius, length):
    """Number of pairs overlapping and approaching (cell list), for tests and checks."""
    n, dim = pos.shape
    rmax = 0.0
    for i in range(n):
        rmax = max(rmax, radius[i])
    nc = _cells_per_axis(length, 2.0 * rmax * 1.00001, n, dim)
    cell = np.empty(n, np.int64)
    for i in range(n):
        g = 0
        for d in range(dim - 1, -1, -1):
            g = g * nc + _cell_coord(pos[i, d], length, nc)
        cell[i] = g
    order = np.argsort(cell, kind="mergesort")
    cpos = np.empty((n, dim))
    cvel = np.empty((n, dim))
    crad = np.empty(n)
    cend = np.zeros(nc ** dim, np.int64)
    for q in range(n):
        cpos[q] = pos[order[q]]
        cvel[q] = vel[order[q]]
        crad[q] = radius[order[q]]
        cend[cell[q]] += 1
    for g in range(1, nc ** dim):
        cend[g] += cend[g - 1]
    cstart = cend.copy()
    for q in range(n):
        cstart[cell[q]] -= 1
    act = np.ones(n, np.int64)
    age = np.full(n, np.inf)
    ci = np.empty(16, np.int64)
    cj = np.empty(16, np.int64)
    ct = np.empty(16, np.float64)
    left = np.array([0.0, 1.0])
    support = np.zeros((n, dim + 1))
    return _search_rows(np.empty(0, np.int64), 0, n, cpos, cvel, crad, age, act, 1, order, True, np.zeros(n), 0.0,
                        2.0 * rmax, 0.0, 0.0, length, nc, cstart, cend, False, 0, ci, cj, ct, left, support)


@njit
def _search_cells(lo1, hi1, lo2, hi2, pos, vel, radius, age, ident, sigma_max, nc, cstart, cend, k, cand_i,
                  cand_j, cand_tau, left, support):
    """The first pass's pairs in contact under the overlap rule with a member in the cells (c0,
    c1, c2), c1 in [lo1, hi1), c2 in [lo2, hi2) (a patch), cells at least sigma_max wide, every
    particle active: each pair of neighbouring cells
    is examined once, from the cell of the two that comes first in the half shell (the same
    cell, the next along axis 0, the next row, the next plane), so each pair is met once,
    without an ident test: half the work of :func:`gaz_cli.engines.step.contacts._search_rows` from every particle. A pair is
    written with the lower ident first (as :func:`gaz_cli.engines.step.contacts._search_rows` would); ``left`` as there. Returns
    the new count."""
    dim = pos.shape[1]
    s2 = sigma_max * sigma_max * (1.0 + 1e-9)  # above any pair's sigma^2 and its round-off
    shrink = (1.0 - OVERLAP_TOL) * (1.0 - OVERLAP_TOL) - 1.0
    for c2 in range(lo2, hi2):
        for c1 in range(lo1, hi1):
            for c0 in range(nc):
                g = (c2 * nc + c1) * nc + c0
                lo0 = c0 - 1 if c0 > 0 else 0
                hi0 = c0 + 1 if c0 + 1 < nc else nc - 1
                nrows = 1
                if dim > 1 and c1 + 1 < nc:
                    nrows = 2
                if dim > 2 and c2 + 1 < nc:
                    nrows = 5
                k1lo = c1 - 1 if c1 > 0 else 0
                for i in range(cstart[g], cend[g]):
                    for r in range(nrows):
                        if r == 0:  # the same cell (j after i) and the next one along axis 0
                            lo = i + 1
                            hi = cend[hi0 + g - c0]
                        elif r == 1:  # the next row of the same plane
                            if not (dim > 1 and c1 + 1 < nc):
                                continue
                            row = (c2 * nc + c1 + 1) * nc
                            lo = cstart[row + lo0]
                            hi = cend[row + hi0]
                        else:  # three rows of the next plane
                            k1 = k1lo + r - 2
                            if k1 >= nc or k1 > c1 + 1:
                                continue
                            row = ((c2 + 1) * nc + k1) * nc
                            lo = cstart[row + lo0]
                            hi = cend[row + hi0]
                        for j in range(lo, hi):
                            r2 = 0.0
                            for d in range(dim):
                                dr = pos[j, d] - pos[i, d]
                                r2 += dr * dr
                            if r2 >= s2:
                                continue  # farther apart than the widest pair: most of those met
                            a, b = (i, j) if ident[i] < ident[j] else (j, i)
                            amax = age[a] if age[a] < age[b] else age[b]
                            sigma = radius[a] + radius[b]
                            tau, c = _contact_tau(pos, vel, a, b, sigma, amax, False, support)
                            k = _keep_pair(a, b, tau, c, sigma, True, shrink, left, k, cand_i, cand_j, cand_tau)
    return k
