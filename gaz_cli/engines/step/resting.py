"""Resting contacts: particles a wall holds at rest until the step's end, particles resting on
held ones, the weight passed down to the floor's row, and the release of a held particle that a
collision takes off.
"""

from __future__ import annotations

import math

from gaz_cli.engines.step.codes import LIFT_ROUND_OFF
from gaz_cli.engines.step.wall_contact import _rests
from gaz_cli.numba_config import njit


@njit
def _hold(i, normal_sign, d, alpha, e, support, hold_row, row):
    """Note particle i as held by a wall (box axis d, inward normal sign normal_sign, restitution
    e): support[i, :D] = -alpha along the normal (m/s^2, the wall's push that cancels its normal
    acceleration alpha < 0), support[i, D] = e, hold_row[i] = its bounce row (-1: none; a
    particle held by a particle q has -2 - q there, :func:`gaz_cli.engines.step.resting._rest_on`)."""
    dim = support.shape[1] - 1
    for k in range(dim):
        support[i, k] = 0.0
    support[i, d] = -alpha * normal_sign
    support[i, dim] = e
    hold_row[i] = row


@njit
def _release(i, tau, pos, vel, mass, support, hold_row, bf):
    """A particle held by a floor (support[i] != 0) that a collision takes off it tau s before
    the step's end: the floor held it only until then. In the kernel a held particle ends the
    step with the drift velocity that the closing half kick takes to rest, the floor's support
    paid until the step's end; from the contact on it flies freely, so its drift velocity loses
    support tau and its end position support tau^2 / 2 (the free parabola from its resting
    place, at rest at the contact), and its floor row (hold_row[i] >= 0) the support it was
    credited for those tau s: (1 + e_w) m v_perp stays the momentum the floor gave (held by a
    particle, the load it no longer passes on: :func:`_pass_on`).

    Friction aside: with s = |support| (m/s^2), the free path from rest under drag gamma is
    v = -s (1 - e^{-gamma t}) / gamma along the support, not -s t, so the end velocity is off
    by about s gamma tau (h - tau / 2) (h = dt / 2), at most
    |s| gamma dt^2 / 8 (1e-8 m/s for the marbles preset's g 9.81, gamma 0.2 1/s, dt 2e-4 s),
    and the position by O(|s| gamma tau^3). Measured (/tmp/stepfix5/drag_release.py, the
    ball a bead lifts off the floor, test_step_resting.py's kick, against the closed form of
    dv/dt = g - gamma v): at the preset's dt and drag, v_y off by 1.8e-10 m/s (6e-10 of its
    0.3 m/s), y by 8.4e-11 m, as much as kick-drift-kick's own drift under drag gives a ball
    that flies the same path without a release (9.3e-11 m); 1.6e-7 m/s at dt 1e-3, 2e-5 m/s
    at gamma 2, dt 4e-3. Far below the engine's dt error (the preset's pressure moves by 1 %
    from dt to dt / 2), so the release keeps the drag-free formulas."""
    dim = pos.shape[1]
    a2 = 0.0
    for d in range(dim):
        a2 += support[i, d] * support[i, d]
    _pass_on(i, mass[i] * math.sqrt(a2) * tau, tau, pos, vel, mass, support, hold_row, bf)
    for d in range(dim):
        a = support[i, d]
        vel[i, d] -= a * tau
        pos[i, d] -= 0.5 * a * tau * tau
        support[i, d] = 0.0
    hold_row[i] = -1


@njit
def _pass_on(k, load, tau, pos, vel, mass, support, hold_row, bf):
    """Pass the momentum ``load`` (kg m/s along the push of what holds particle k; < 0: into it)
    that k received tau s before the step's end on to its holder: a wall takes it (its row, if
    any, gains -load / m_k, :func:`_credit_row`); a particle q that holds k (hold_row[k] = -2 -
    q) moves with the part of it across its own holder's push, and passes the rest on in
    turn; a holder no longer held takes it all. Velocities change and positions move by
    that change times tau, as in a collision."""
    dim = pos.shape[1]
    for _ in range(pos.shape[0]):
        q = -2 - hold_row[k]
        a = 0.0
        for d in range(dim):
            a += support[k, d] * support[k, d]
        a = math.sqrt(a)
        if q < 0 or a == 0.0:  # a wall (or nothing) holds k
            _credit_row(bf, hold_row[k], -load / mass[k], support[k, dim])
            return
        aq = 0.0
        along = 0.0
        for d in range(dim):
            aq += support[q, d] * support[q, d]
            along += support[k, d] * support[q, d]
        aq = math.sqrt(aq)
        along = along / (a * aq) if aq > 0.0 else 0.0  # cosine between the two pushes
        for d in range(dim):
            imp = load * support[k, d] / a
            if aq > 0.0:
                imp -= load * along * support[q, d] / aq
            vel[q, d] += imp / mass[q]
            pos[q, d] += imp / mass[q] * tau
        if aq == 0.0:
            return
        k = q
        load *= along


@njit
def _credit_row(bf, row, dp, e):
    """Add dp m/s (momentum per mass) to the momentum a bounce row (bf row ``row``; -1: none)
    says its wall (restitution e) gave: its |v_perp| changes by dp / (1 + e), its |v| with it."""
    if row < 0:
        return
    vp = bf[row, 2]
    t2 = bf[row, 1] * bf[row, 1] - vp * vp
    vp += dp / (1.0 + e)
    bf[row, 2] = vp
    bf[row, 1] = math.sqrt(vp * vp + (t2 if t2 > 0.0 else 0.0))


@njit
def _wall_takes(pos, support, i, j, k, dv, nrm, hit, tau):
    """(takes, u_n): whether the wall holding particle k (support (N, D + 1), :func:`gaz_cli.engines.step.resting._hold`) of
    the pair (i, j) takes at once the part u_n (m/s) along its push of the velocity change dv
    nrm that a collision gives k at the contact, tau s before the step's end (dv m/s, nrm (D,)
    the unit line of centres), k staying held: (False, 0.0) when no wall holds k or the
    collision is no impact on it (not ``hit``).

    It does for an impact on k (``hit``, :func:`gaz_cli.engines.step.contacts._held_root`) that does not take k off the wall
    (u_n <= 0 but for the round-off of the line of centres, LIFT_ROUND_OFF) and after which k
    would be back at rest on it within the step (:func:`_rests` of a contact at u_n): the end
    state is then that of the wall's bounce series, k at rest on it, and the wall's momentum
    gains -m u_n. Otherwise a hit k is released (:func:`gaz_cli.engines.step.resting._release`: pushed into the wall, it
    meets it again in the next pass); a partner merely resting on k (not ``hit``) is held by
    it (:func:`gaz_cli.engines.step.resting._rest_on`)."""
    dim = pos.shape[1]
    a2 = 0.0
    un = 0.0
    for d in range(dim):
        a = support[k, d]
        a2 += a * a
        un += a * nrm[d]
    if a2 == 0.0 or not hit:
        return False, 0.0
    a = math.sqrt(a2)
    un *= dv / a
    x = 0.0
    for d in range(dim):
        x = max(x, abs(pos[i, d]), abs(pos[j, d]))
    dist2 = 0.0
    for d in range(dim):
        dist2 += (pos[j, d] - pos[i, d]) ** 2
    if un > LIFT_ROUND_OFF * x / math.sqrt(dist2) * abs(dv):
        return False, un
    return _rests(un if un < 0.0 else 0.0, -a, support[k, dim], tau), un


@njit
def _rest_on(pos, vel, mass, acc, has_pair, g, support, hold_row, bf, i, j, nrm, vn, tau, e):
    """A free particle p resting on a held one k (pair (i, j), nrm (D,) the unit line of centres
    from i to j, vn < 0 m/s their relative normal drift velocity, contact tau s before the
    step's end, not an impact: :func:`gaz_cli.engines.step.contacts._held_root`): the contact carries p's weight, so p is
    held by k in turn (support[p] = -g_n n, g_n < 0 its acceleration towards k along the unit
    n from k to p; restitution e; hold_row[p] = -2 - k). The impulse stops their approach
    along n, p on k: a contact at rest has no speed to give back, whatever e (with e it was a
    series of collisions in each step, e^k, that the passes could not end, and a stack of
    three on a floor of restitution 0.7 sank and fell: 2.988 R, 4.988 R for 3 R, 5 R after 1 s
    at dt 0.05). k moves with the part of the impulse across its holder's push and passes the
    rest on (:func:`_pass_on`): a stack's weight reaches the floor's row in the step. Returns
    the impulse (kg m/s), 0 when neither or both are held or p is not pressed on k (seed
    002's rule then)."""
    dim = pos.shape[1]
    hi = False
    hj = False
    for d in range(dim):
        hi = hi or support[i, d] != 0.0
        hj = hj or support[j, d] != 0.0
    if hi == hj:
        return 0.0
    k, p, sign = (i, j, 1.0) if hi else (j, i, -1.0)  # n = sign nrm, from k to p
    g_n = 0.0
    a = 0.0
    c = 0.0
    for d in range(dim):
        acc_d = acc[p, d] if has_pair else 0.0
        if d == dim - 1:
            acc_d -= g
        g_n += acc_d * sign * nrm[d]
        a += support[k, d] * support[k, d]
        c += support[k, d] * sign * nrm[d]
    if g_n >= 0.0:
        return 0.0
    a = math.sqrt(a)
    c /= a  # cosine between n and k's support
    w = 1.0 / mass[p] + max(1.0 - c * c, 0.0) / mass[k]
    jr = -vn / w  # the impulse on p along n, on k against it
    for d in range(dim):
        n_d = sign * nrm[d]
        dvp = jr / mass[p] * n_d
        dvk = -jr / mass[k] * (n_d - c * support[k, d] / a)  # across k's support
        vel[p, d] += dvp
        pos[p, d] += dvp * tau
        vel[k, d] += dvk
        pos[k, d] += dvk * tau
    _pass_on(k, -jr * c, tau, pos, vel, mass, support, hold_row, bf)
    for d in range(dim):
        support[p, d] = -g_n * sign * nrm[d]
    support[p, dim] = e
    hold_row[p] = -2 - k
    return jr
