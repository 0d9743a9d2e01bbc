"""Box walls and extra planes: which wall a particle met first in a step, the bounce off it
(with its rows: one per hop of a series on a floor), and the safety net after the pass limit.
"""

from __future__ import annotations

import math

from gaz_cli.engines.step.codes import (C_BOUNCES, C_FOLDED, C_PLANE, MAX_HOP_ROWS, SWEEP_BOUNCES,
                                        _grow_f, _grow_i)
from gaz_cli.engines.step.resting import _hold
from gaz_cli.engines.step.wall_contact import (_excursion_tau, _rests, _settle, _velocity_at,
                                               _wall_contact, _bounce_sum)
from gaz_cli.numba_config import njit


@njit
def _box_alpha(acc, i, d, sign, g):
    """Acceleration of particle i along the inward normal ``sign`` (+1 or -1) of a box wall of
    axis d, m/s^2: gravity (last axis) and the pair attraction acc (N, D) at the step's start
    (zeros without pair forces). Constant over the step, it makes kick-drift-kick's path
    the parabola :func:`gaz_cli.engines.step.wall_contact._wall_contact` goes back along: without the attraction, a bounce of
    attracting bodies was met with the wrong speed, an energy error of order dt a bounce."""
    a = acc[i, d] - g if d == acc.shape[1] - 1 else acc[i, d]
    return sign * a


@njit
def _plane_alpha(acc, planes, i, p, g):
    """As :func:`gaz_cli.engines.step.walls._box_alpha` for extra plane p (planes (P, 2D+1): point, unit inward normal,
    restitution)."""
    dim = acc.shape[1]
    a = -g * planes[p, 2 * dim - 1]
    for d in range(dim):
        a += acc[i, d] * planes[p, dim + d]
    return a


@njit
def _box_bounce(i, d, upper, pos, vel, acc, radius, age, length, ew, g, h, hr, gamma, t_end, want, bf, bi, nb,
                support, hold_row):
    """Bounce particle i off the box wall of axis d (upper: at L - R, else at R) it has crossed.

    Taken back to its contact (:func:`gaz_cli.engines.step.wall_contact._wall_contact`), its normal velocity
    reversed and scaled by ``ew``, moved forward to the end of the step. An
    invalid state (no contact within its age) is put on the wall, its
    velocity reversed if still moving out. The bounce is recorded in bf (t,
    |v|, |v_perp| at contact, :func:`_velocity_at`) and bi (particle, RE_DIR) at row nb when
    ``want``, and so is each later bounce of a series of hops on a floor within the step
    (:func:`gaz_cli.engines.step.walls._hop_rows`). Returns (bf, bi, nb, bounces recorded, bounces folded into the last
    row of a series longer than MAX_HOP_ROWS). A particle that comes to rest on the wall is
    noted as held by it (:func:`gaz_cli.engines.step.resting._hold`).
    """
    r = radius[i]
    sign = -1.0 if upper else 1.0  # inward normal along axis d
    alpha = _box_alpha(acc, i, d, sign, g)
    d_e = (length - r - pos[i, d]) if upper else (pos[i, d] - r)
    w_h = sign * vel[i, d]
    tau, w_c, d_new, w_new, v_rec, hops = _wall_contact(d_e, w_h, alpha, h, hr, gamma, age[i], ew)
    rest = tau >= 0.0 and _rests(w_c, alpha, ew, tau)
    tau, w_c, d_new, w_new, v_rec, hops = _settle(tau, w_c, d_new, w_new, v_rec, hops, w_h, ew, alpha, h)
    bounced = 0
    folded = 0
    if tau >= 0.0:
        rows = hops if hops <= MAX_HOP_ROWS else MAX_HOP_ROWS
        if rest:
            _hold(i, sign, d, alpha, ew, support, hold_row, nb if want else -1)
        if want:
            code = (d + 1) if upper else -(d + 1)
            t2 = _tangential2(vel, acc, i, d, g, h - tau, gamma)
            bf, bi, nb = _add_bounce_row(bf, bi, nb, t_end - tau, v_rec, t2, i, code)
            if hops > 0:
                bf, bi, nb = _hop_rows(bf, bi, nb, t_end - tau, h - tau, -ew * w_c, alpha, ew, hops, rows,
                                       vel, acc, g, gamma, i, d, code)
        bounced = 1 + rows
        folded = hops - rows
        if tau < age[i]:
            age[i] = tau
    if d_new < 0.0:
        d_new = 0.0
    pos[i, d] = (length - r - d_new) if upper else (r + d_new)
    vel[i, d] = sign * w_new
    return bf, bi, nb, bounced, folded


@njit
def _add_bounce_row(bf, bi, nb, t, vperp, t2, i, code):
    """Write one bounce (time s, |v| from |v_perp| and the tangential speed squared t2, |v_perp|
    m/s; particle, RE_DIR) at row nb, growing the buffers as needed; returns (bf, bi, nb)."""
    if nb >= bf.shape[0]:
        bf = _grow_f(bf)
        bi = _grow_i(bi)
    bf[nb, 0] = t
    bf[nb, 1] = math.sqrt(vperp * vperp + t2)
    bf[nb, 2] = vperp
    bi[nb, 0] = i
    bi[nb, 1] = code
    return bf, bi, nb + 1


@njit
def _tangential2(vel, acc, i, d, g, s, gamma):
    """Squared speed of particle i along the axes other than d, s seconds after the step's middle
    (:func:`_velocity_at`; acc (N, D) the pair attraction, gravity g along the last axis)."""
    dim = vel.shape[1]
    t2 = 0.0
    for k in range(dim):
        if k != d:
            a = acc[i, k] - g if k == dim - 1 else acc[i, k]
            v = _velocity_at(vel[i, k], a, s, gamma)
            t2 += v * v
    return t2


@njit
def _hop_rows(bf, bi, nb, t_c, s_c, u, alpha, e, hops, rows, vel, acc, g, gamma, i, d, code):
    """The bounces of a series of hops on a floor that follow a contact at t_c s within its step.

    Launched at u m/s from t_c (s_c s after the step's middle), flight k lasts t0 e^k (t0 = 2 u / |alpha|); bounce k
    (k = 1..hops) comes at t_c + :func:`_bounce_sum` (t0, e, k) with |v_perp| = u e^(k-1), the
    speed it left at. ``rows`` (<= hops) rows are written: when hops > rows, the last one
    carries the |v_perp| of bounces rows..hops summed, so that sum (1 + e) m |v_perp| stays
    the momentum the wall gave. Returns (bf, bi, nb)."""
    t0 = -2.0 * u / alpha
    w = u
    for k in range(1, rows + 1):
        vp = w
        if k == rows and hops > rows:
            vp = w * _bounce_sum(1.0, e, hops - rows + 1)
        after = _bounce_sum(t0, e, k)
        bf, bi, nb = _add_bounce_row(bf, bi, nb, t_c + after, vp, _tangential2(vel, acc, i, d, g, s_c + after, gamma),
                                     i, code)
        w *= e
    return bf, bi, nb


@njit
def _plane_distance(pos, vel, planes, i, p):
    """(distance of particle i's centre from extra plane p along its inward normal, its
    velocity along that normal); planes (P, 2D+1): point, unit inward normal, restitution."""
    dim = pos.shape[1]
    dist = 0.0
    w_h = 0.0
    for d in range(dim):
        nd = planes[p, dim + d]
        dist += (pos[i, d] - planes[p, d]) * nd
        w_h += vel[i, d] * nd
    return dist, w_h


@njit
def _plane_bounce(i, p, pos, vel, acc, radius, age, planes, g, h, hr, gamma, support, hold_row):
    """Bounce particle i off extra plane p (planes (P, 2D+1): point, unit inward normal, restitution).

    Same contact rule as the box walls (:func:`gaz_cli.engines.step.wall_contact._wall_contact`); returns the bounces (1 and
    the hops that followed within the step), 0 if it was only put back on the plane (invalid
    state).
    """
    dim = pos.shape[1]
    dist, w_h = _plane_distance(pos, vel, planes, i, p)
    d_e = dist - radius[i]
    e = planes[p, 2 * dim]
    alpha = _plane_alpha(acc, planes, i, p, g)
    tau, w_c, d_new, w_new, v_rec, hops = _wall_contact(d_e, w_h, alpha, h, hr, gamma, age[i], e)
    rest = tau >= 0.0 and _rests(w_c, alpha, e, tau)
    tau, w_c, d_new, w_new, v_rec, hops = _settle(tau, w_c, d_new, w_new, v_rec, hops, w_h, e, alpha, h)
    bounced = 0
    if tau >= 0.0:
        bounced = 1 + hops
        if rest:  # held by the plane: its support along the plane's normal, no row
            for d in range(dim):
                support[i, d] = -alpha * planes[p, dim + d]
            support[i, dim] = e
            hold_row[i] = -1
        if tau < age[i]:
            age[i] = tau
    if d_new < 0.0:
        d_new = 0.0
    for d in range(dim):
        nd = planes[p, dim + d]
        pos[i, d] += (d_new - d_e) * nd
        vel[i, d] += (w_new - w_h) * nd
    _in_front(pos, planes, i, p, radius[i])
    return bounced


@njit
def _in_front(pos, planes, i, p, r):
    """Move particle i's centre along extra plane p's normal until it is at least r m from the
    plane. The move onto a tilted plane rounds (a few ulps of the coordinates), and a centre
    left that little behind it was a contact again in every pass: a ball sliding on a plane of
    slope 0.2 cost 41 passes and 9.4 plane contacts a step at dt 1e-3 for 2 and 1."""
    dim = pos.shape[1]
    scale = 0.0
    for d in range(dim):
        scale = max(scale, abs(pos[i, d]), abs(planes[p, d]))
    for _ in range(8):
        dist = 0.0
        for d in range(dim):
            dist += (pos[i, d] - planes[p, d]) * planes[p, dim + d]
        if dist >= r:
            return
        step = max(r - dist, 2.220446049250313e-16 * scale)
        for d in range(dim):
            pos[i, d] += step * planes[p, dim + d]


@njit
def _earliest_wall(i, pos, vel, acc, radius, age, last, length, ew, g, h, hr, gamma, planes, with_planes):
    """(w, tau): the box wall (w = 2 d + upper) or, ``with_planes``, extra plane (w = 2 D + p)
    particle i met first, and the time back to it (s; 0 for an invalid state); (-1, -1.0) for
    none. A wall counts when the particle is beyond it, or in front of it after an excursion
    beyond (:func:`_excursion_tau`), except the wall ``last`` (N,) says its path bent at last
    (it moves away from it since). Ties go to the lowest w."""
    dim = pos.shape[1]
    best = -1
    best_tau = -1.0
    r = radius[i]
    for d in range(dim):
        x = pos[i, d]
        for up in range(2):
            w = 2 * d + up
            sign = -1.0 if up == 1 else 1.0
            alpha = _box_alpha(acc, i, d, sign, g)
            d_e = (length - r - x) if up == 1 else (x - r)
            if d_e >= 0.0:  # in front of it: an excursion beyond?
                if alpha <= 0.0 or last[i] == w:
                    continue
                tau = _excursion_tau(d_e, sign * vel[i, d], alpha, h, hr, gamma, age[i], ew)
                if tau < 0.0:
                    continue
            else:
                tau = _wall_contact(d_e, sign * vel[i, d], alpha, h, hr, gamma, age[i], ew)[0]
                if tau < 0.0:
                    tau = 0.0
            if tau > best_tau:
                best = w
                best_tau = tau
    if with_planes:
        for p in range(planes.shape[0]):
            dist, w_h = _plane_distance(pos, vel, planes, i, p)
            alpha = _plane_alpha(acc, planes, i, p, g)
            if dist >= r:
                if last[i] == 2 * dim + p:
                    continue
                tau = _excursion_tau(dist - r, w_h, alpha, h, hr, gamma, age[i], planes[p, 2 * dim])
                if tau >= 0.0 and tau > best_tau:
                    best = 2 * dim + p
                    best_tau = tau
                continue
            tau = _wall_contact(dist - r, w_h, alpha, h, hr, gamma, age[i], planes[p, 2 * dim])[0]
            if tau < 0.0:
                tau = 0.0
            if tau > best_tau:
                best = 2 * dim + p
                best_tau = tau
    return best, best_tau


@njit
def _wall_rows(rows, first, last, pos, vel, acc, radius, age, last_wall, length, ew, g, h, hr, gamma, planes, still, k,
               cand_i, cand_j, cand_tau):
    """Write the first wall or plane crossing of the particles i = rows[first:last] (rows first
    to last of the arrays when ``rows`` is empty) from row k; returns the new count.

    Wall w is coded j = -1 - w: box walls w = 2 d + upper, planes w = 2 D + p
    (:func:`gaz_cli.engines.step.walls._earliest_wall`, ``last_wall`` its ``last``; a pass applies at most one contact a
    particle, its earliest). tau = time back to the contact, 0 for an invalid state (handled
    last). Rows beyond the arrays' size are counted, not written: the caller grows the arrays
    and scans again. When ``still`` (no gravity, no pair force: every wall's normal
    acceleration is 0, so only a wall the centre is beyond counts) and there is no plane, a
    centre within [R, L - R] on every axis is passed over at once (a few ns, where the full
    check costs tens).
    """
    dim = pos.shape[1]
    quick = still and planes.shape[0] == 0
    for m in range(first, last):
        i = rows[m] if rows.size > 0 else m
        if quick:
            r = radius[i]
            inside = True
            for d in range(dim):
                x = pos[i, d]
                if x - r < 0.0 or length - r - x < 0.0:
                    inside = False
            if inside:
                continue
        w, tau = _earliest_wall(i, pos, vel, acc, radius, age, last_wall, length, ew, g, h, hr, gamma, planes, True)
        if w < 0:
            continue
        if k < cand_i.shape[0]:
            cand_i[k] = i
            cand_j[k] = -1 - w
            cand_tau[k] = tau
        k += 1
    return k


@njit
def _apply_wall(i, w, pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma, t_end, want, bf, bi,
                nb, counters, support, hold_row):
    """Bounce particle i off wall w (box walls w = 2 d + upper, planes 2 D + p), counted in
    counters, noted in last (N,); returns (bf, bi, nb)."""
    dim = pos.shape[1]
    last[i] = w
    if w < 2 * dim:
        bf, bi, nb, b, f = _box_bounce(i, w // 2, w % 2 == 1, pos, vel, acc, radius, age, length, ew, g, h, hr,
                                       gamma, t_end, want, bf, bi, nb, support, hold_row)
        counters[C_BOUNCES] += b
        counters[C_FOLDED] += f
    else:
        counters[C_PLANE] += _plane_bounce(i, w - 2 * dim, pos, vel, acc, radius, age, planes, g, h, hr, gamma,
                                           support, hold_row)
    return bf, bi, nb


@njit
def _walls_sweep(rows, pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma, t_end, want, bf, bi,
                 nb, counters, support, hold_row):
    """Safety net after the pass limit: every particle beyond a box wall bounces, earliest contact
    first, until it is inside the box (a particle crossing the box many times in one step gets
    every bounce); then once off each plane it is behind; then any centre still outside
    [R, L - R] (after SWEEP_BOUNCES bounces, or pushed out by a plane) is put on the wall.
    The particles are taken in the order of ``rows`` (their rows in the caller's numbering,
    so that the bounce rows come in the same order whatever the layout). Returns (bf, bi, nb)."""
    dim = pos.shape[1]
    for i in rows:
        for _ in range(SWEEP_BOUNCES):
            w = _earliest_wall(i, pos, vel, acc, radius, age, last, length, ew, g, h, hr, gamma, planes, False)[0]
            if w < 0:
                break
            bf, bi, nb = _apply_wall(i, w, pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma,
                                     t_end, want, bf, bi, nb, counters, support, hold_row)
        for p in range(planes.shape[0]):
            dist = 0.0
            for d in range(dim):
                dist += (pos[i, d] - planes[p, d]) * planes[p, dim + d]
            if dist < radius[i]:
                counters[C_PLANE] += _plane_bounce(i, p, pos, vel, acc, radius, age, planes, g, h, hr, gamma,
                                                   support, hold_row)
                last[i] = 2 * dim + p
        r = radius[i]
        for d in range(dim):
            if pos[i, d] < r:
                pos[i, d] = r
            elif pos[i, d] > length - r:
                pos[i, d] = length - r
    return bf, bi, nb
