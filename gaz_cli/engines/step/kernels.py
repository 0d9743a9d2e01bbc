"""Numba kernels of the time-stepped engine (seeds 002 and 003).

Private, plain kernels on contiguous arrays: they never raise, they return
counts and (possibly reallocated) buffers. The driver :func:`_advance` runs a
block of steps; each step is, in order:

1. half kick  ``v <- v e^{-gamma h} + a (1 - e^{-gamma h}) / gamma`` over
   h = dt/2, the exact solution for a constant acceleration a (gravity plus
   pair attraction at the current positions) and linear friction; ``v += a h``
   without friction; skipped entirely when the scene has no force;
2. drift ``x += v dt`` (straight lines, so going back along them is exact);
3. contact passes. Each pass lists the contacts of the *active* particles
   (all of them in the first pass): the first crossing of a box wall or an
   extra plane (one it ends beyond, or one a path bending away from it went
   beyond and came back from: :func:`_earliest_wall`), and pairs in contact
   found with a cell list (never O(N^2)). They
   are sorted by contact time, earliest first, and applied in that order, a
   particle taking part in at most one contact per pass: a pair is taken back
   to its contact time along its straight segment, its velocities are changed
   along the line of centres (any masses, restitution e, TC model; the
   impulse of the velocities at the contact time, see :func:`_collide`), and
   it is moved forward to the end of the step; a wall contact does the same
   with the wall (restitution, exact under uniform gravity, the pair
   attraction taken constant over the step, see :func:`_wall_contact`); a particle that comes
   to rest on a floor is *held* by it until the step's end (:func:`_hold`), a particle resting
   on a held one is held by it in turn, its weight passed on to the floor
   (:func:`_rest_on`), and a collision that takes one off releases it there: it flies freely
   from the contact (:func:`_release`). The particles that moved are the next pass's
   active set; passes repeat until a pass finds nothing or the pass limit
   is hit (then every particle still beyond a box wall bounces until it is
   inside, and off the planes once: :func:`_walls_sweep`);
4. pair accelerations at the new positions (when pair gravity is on);
5. half kick.

Contact rule (physics.md section 9): with dr = r_j - r_i, dv = v_j - v_i at the
end of the step, a = |dv|^2, b = dr.dv, c = |dr|^2 - sigma^2, going back by tau
gives |dr - dv tau|^2 = a tau^2 - 2 b tau + c. ``overlap`` detection (seed
002): a pair collides when c < 0 and b < 0, at tau = -c / (sqrt(b^2 - a c) - b)
(the cancellation-free root). ``swept`` detection also catches the pairs that
touched during the step and no longer approach at its end (grazing contacts):
tau = (b + sqrt(b^2 - a c)) / a when b >= 0. In both, tau is limited by the
particles' *age*, the time since their trajectory last bent in this step, so
going back never leaves the real straight segment.

Times of the phases are read with clock_gettime(CLOCK_MONOTONIC) from inside
the kernel (about 30 ns a call).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange, types

from gaz_cli.numba_config import njit, pnjit

"""Parallel kernels (prange over particles)."""

PARALLEL_PAIR_MIN = 1024
"""Pair-force sums use the parallel kernel from this many bodies on: a sum then takes milliseconds,
so starting the threads costs little; with one thread the parallel kernel runs as fast as the serial
one, with two idle cores twice as fast (on a machine whose cores are busy, threads only add waiting)."""

# status codes of _advance
DONE = 0
"""All requested steps were run."""
FLUSH = 1
"""Stopped early: the event buffers are full enough to be handed to the recorder."""
PAUSE = 2
"""Stopped early: the call's wall-clock deadline passed (control goes back to Python, so that
Ctrl-C is seen within a slice)."""

# counters (int64 array) of _advance
C_BOUNCES, C_COLLISIONS, C_PASSES, C_PASS_LIMIT, C_PLANE, C_MAX_PASSES, C_PAIR_EVALS, C_STEPS = range(8)
C_OVERLAP_STEPS, C_OVERLAP_PAIRS, C_OVERLAP_MAX = range(8, 11)
"""Steps that ended with overlapping pairs, such pairs summed over the steps, the most at one
step end."""
C_FOLDED = 11
"""Bounces of long series of hops on a floor that got no row of their own (see MAX_HOP_ROWS)."""
N_COUNTERS = 12
MAX_HOP_ROWS = 1000
"""Rows a series of hops on a floor after one contact gets within a step, each bounce its own
row; a longer series (hops shorter than dt / 1000: a ball barely off an elastic floor, whose
hops round-off can make arbitrarily short) puts the bounces beyond in its last row, their
momentum summed (counted in C_FOLDED)."""
G_CLOSEST, G_FIRST_TIME = range(2)
"""The float overlap record (2,): smallest |dr| / sigma at a step end, time of the first step
end with an overlapping pair (s; initialise with 1.0 and nan)."""
OVERLAP_TOL = 0.01
"""A pair counts as left overlapping when, at the first contact pass of a step (all particles
drifted), it is closer than (1 - OVERLAP_TOL) sigma and the contact rule leaves it alone
(overlapping and separating): it stays so at the step's end unless a later pass moves one of
the two. Contacts
found are resolved to round-off, but the overlap rule misses grazing ones that enter and leave
the contact distance within one step, whatever dt: with a relative displacement l = |dv| dt per
step they end at most l^2 / (8 sigma) deep (a chord of length l), so a 1% overlap means the
particles move about 0.3 sigma relative to each other in a step: dt is too long."""
LIFT_ROUND_OFF = 64.0 * 2.220446049250313e-16
"""Round-off of the normal part of a line of centres, per (largest coordinate / centres'
distance): two balls a wall holds sit on it to a few ulps of their coordinates, so their line
of centres is parallel to it within a few eps x |x| / sigma (64 eps leaves room for the
projections and differences); a collision between them lifts neither (:func:`_wall_takes`)."""
SPEED_ROUND_OFF = 4.0 * 2.220446049250313e-16
"""Round-off of a relative velocity, per the particles' speeds |v_i| + |v_j|: the difference of
two velocities is exact to eps of their size, and an impulse below an ulp of them changes
nothing. A pair approaching no faster than that is at rest against each other (a stack's balls,
both held: with restitution 0 they met again pass after pass at 4e-19 m/s until the pass limit,
and the stack sank by 0.02 R in 1 s at dt 1e-3)."""
SWEEP_BOUNCES = 1 << 20
"""Box-wall bounces of one particle in the safety net after the pass limit (:func:`_walls_sweep`):
a particle crossing the box that many times in one step is put back on the wall."""
# phase clocks (float64 array, seconds)
T_PUSH, T_COLLISIONS, T_WALLS = range(3)
N_TIMERS = 3

_clock_gettime = types.ExternalFunction("clock_gettime", types.int32(types.int32, types.voidptr))


@njit
def _now(clock_id, buf):
    """Monotonic clock, s; ``buf`` (2,) int64 scratch; clock_id < 0 disables timing (returns 0)."""
    if clock_id < 0:
        return 0.0
    _clock_gettime(clock_id, buf.ctypes.data)
    return buf[0] + 1e-9 * buf[1]


# --- buffers -------------------------------------------------------------------
@njit
def _grow_f(a):
    """Double the rows of a 2D float64 buffer, keeping its content."""
    out = np.empty((2 * a.shape[0] + 16, a.shape[1]), dtype=np.float64)
    out[: a.shape[0]] = a
    return out


@njit
def _grow_i(a):
    """Double the rows of a 2D int64 buffer, keeping its content."""
    out = np.empty((2 * a.shape[0] + 16, a.shape[1]), dtype=np.int64)
    out[: a.shape[0]] = a
    return out


# --- forces --------------------------------------------------------------------
@njit
def _add_pair(pos, mass, G, eps2, i, j, acc):
    """The Plummer-softened pull between bodies i and j added to their rows of acc (N, D)."""
    r2 = eps2
    for d in range(pos.shape[1]):
        dx = pos[j, d] - pos[i, d]
        r2 += dx * dx
    if r2 <= 0.0:
        return
    inv = G / (r2 * math.sqrt(r2))
    for d in range(pos.shape[1]):
        dx = pos[j, d] - pos[i, d]
        acc[i, d] += mass[j] * inv * dx
        acc[j, d] -= mass[i] * inv * dx


@njit
def _pair_acc_serial(pos, mass, G, eps2, acc):
    """Plummer-softened Newtonian accelerations, O(N^2/2), into acc (N, D) m/s^2."""
    n = pos.shape[0]
    acc[:] = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            _add_pair(pos, mass, G, eps2, i, j, acc)


@pnjit
def _pair_acc_parallel(pos, mass, G, eps2, acc, nthreads):
    """As :func:`_pair_acc_serial`, the N^2/2 pairs shared among ``nthreads`` threads.

    Thread t takes the rows i = t, t + nthreads, ... (balanced over the
    triangle j > i) and accumulates into its own (N, D) buffer; the buffers
    are summed at the end (no races, no atomics).
    """
    n, dim = pos.shape
    buf = np.zeros((nthreads, n, dim))
    for t in prange(nthreads):
        mine = buf[t]
        for i in range(t, n, nthreads):
            for j in range(i + 1, n):
                _add_pair(pos, mass, G, eps2, i, j, mine)
    for i in prange(n):
        for d in range(dim):
            s = 0.0
            for t in range(nthreads):
                s += buf[t, i, d]
            acc[i, d] = s


@njit
def _pair_acc(pos, mass, G, eps2, acc, nthreads):
    """Pair accelerations, serial for few bodies (or one thread), parallel over nthreads for many."""
    if pos.shape[0] >= PARALLEL_PAIR_MIN and nthreads > 1:
        _pair_acc_parallel(pos, mass, G, eps2, acc, nthreads)
    else:
        _pair_acc_serial(pos, mass, G, eps2, acc)


@njit
def _pair_potential(pos, mass, G, eps2):
    """Total pair potential energy -sum_{i<j} G m_i m_j / sqrt(r^2 + eps^2), J."""
    n, dim = pos.shape
    u = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            r2 = eps2
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 > 0.0:
                u -= G * mass[i] * mass[j] / math.sqrt(r2)
    return u


@njit
def _kick(vel, acc, has_pair, g, gamma, h):
    """Half kick over h s: exact for constant acceleration (acc + gravity) with linear friction.

    Separate loops per force set: gravity alone touches only the last column.
    """
    n, dim = vel.shape
    if gamma > 0.0:
        f = math.exp(-gamma * h)
        c = -math.expm1(-gamma * h) / gamma
        for i in range(n):
            for d in range(dim):
                vel[i, d] *= f
    else:
        c = h
    if g > 0.0:
        dv = g * c
        for i in range(n):
            vel[i, dim - 1] -= dv
    if has_pair:
        for i in range(n):
            for d in range(dim):
                vel[i, d] += acc[i, d] * c


@njit
def _drift(pos, vel, dt, age):
    """Straight flight over dt s; every particle's age (time since its path bent) becomes dt."""
    n, dim = pos.shape
    for i in range(n):
        for d in range(dim):
            pos[i, d] += vel[i, d] * dt
        age[i] = dt


# --- walls ---------------------------------------------------------------------
@njit
def _wall_contact(d_e, w_h, alpha, h, hr, gamma, age, e):
    """Contact of one particle with one wall, along the wall's inward normal.

    d_e (m): signed distance of the centre from its contact position at the
    end of the step (< 0: beyond the wall); w_h (m/s): normal drift velocity;
    alpha (m/s^2): normal acceleration, gravity and the pair attraction at
    the step's start (:func:`_box_alpha`; 0 for a wall parallel to gravity
    without pair forces, < 0 for a floor); h = dt/2; hr (s): the drift velocity -alpha hr ends
    the step at normal velocity 0 (h without friction, expm1(gamma h) / gamma
    with); gamma (1/s): friction; age (s); e: restitution. Under uniform gravity the path is a
    parabola whose end point and end velocity w_h + alpha h are exact in
    kick-drift-kick, so going back along it finds the exact contact.

    Resting and hopping: on a floor (alpha < 0) the particle leaves the
    contact at -e w_c and bounces on, each flight e times the last, all of
    them within 2 e |w_c| / (|alpha| (1 - e)) s. When that is at most tau
    (always for e = 0) it rests on the wall at the step's end: d_new = 0,
    normal velocity 0 after the closing half kick. Otherwise the end state is
    that of the flight under way at the step's end (:func:`_last_flight`):
    the particle is never left below the wall with the velocity of a flight
    that the wall cut short. A floor crossed with no contact on the parabola
    within the age (round-off at a tangency: a particle resting from the
    step's start, its end velocity alpha dt) is a contact at the start of
    the age with w_c = min(its normal velocity then, 0): a resting particle
    stays at rest instead of bouncing off a made-up speed |alpha| dt.

    Returns (tau, w_c, d_new, w_h_new, v_rec, hops): the time back to the
    contact (s; -1: none within the age, an invalid state), the normal
    velocity just before it (<= 0), the new end distance and normal drift
    velocity, the normal speed to record for the contact and the number of
    bounces that followed it within the step, each its own bounce (hopping:
    bounce k, k = 1..hops, comes :func:`_bounce_sum` (t0, e, k) s after the
    contact at the speed e^(k-1) u, u = e |w_c|, t0 = 2 u / |alpha|; see
    :func:`_hop_rows`). v_rec is the normal speed at the contact (|w_c|,
    friction aside: :func:`_velocity_at`; the end speed for an invalid
    state), except when the particle came to
    rest within the step (infinitely many bounces for e > 0, or a resting
    contact): then it is the momentum per mass the wall gave it from the
    contact to the step's end (w_end - w_0 + |alpha| tau, by momentum
    balance) over 1 + e, so that the record's (1 + e) m v_rec (Q36, the
    pressure) counts the bounces of the series and the weight carried: a
    particle resting on the floor records one bounce a step, of v_rec =
    |alpha| dt / (1 + e). w_0 is w_c, or for a floor met at the start of
    the age the normal velocity then even when moving in (w_c is 0 then):
    a resting particle that a collision pushed towards the floor, its path
    beyond it since, is stopped by it and records exactly the momentum it
    lost, so that the rows sum to the momentum the walls gave
    (tests/test_step_momentum.py).
    """
    w_e = w_h + alpha * h
    tau = -1.0
    if alpha == 0.0:
        if w_e < 0.0:
            tau = d_e / w_e
    else:
        disc = w_e * w_e - 2.0 * alpha * d_e
        if disc >= 0.0:
            # 0.5 alpha tau^2 - w_e tau + d_e = 0, cancellation-free roots
            sq = math.sqrt(disc)
            q = 0.5 * (w_e + sq) if w_e >= 0.0 else 0.5 * (w_e - sq)
            r1 = q / (0.5 * alpha)
            r2 = d_e / q if q != 0.0 else -1.0
            for r in (r1, r2):
                if r >= 0.0 and w_e - alpha * r < 0.0 and (tau < 0.0 or r < tau):
                    tau = r
    if tau < 0.0 or tau > age:
        if alpha >= 0.0 or w_e >= 0.0:
            return -1.0, w_e, 0.0, w_h, -_velocity_at(w_h, alpha, h, gamma), 0
        tau = age  # a floor, still moving out at the end: on it at the start of the age
    w_0 = w_e - alpha * tau  # normal velocity at the contact, or at the start of the age (> 0: moving in)
    w_c = w_0 if w_0 < 0.0 else 0.0
    w_out = -e * w_c
    if _rests(w_c, alpha, e, tau):
        return tau, w_c, 0.0, -alpha * hr, -(w_0 + alpha * tau) / (1.0 + e), 0
    s = tau  # time of flight since the last bounce, launched at w_out
    hops = 0
    if alpha < 0.0 and 2.0 * w_out < -alpha * tau:
        s, w_out, hops = _last_flight(w_out, alpha, e, tau)
    d_new = w_out * s + 0.5 * alpha * s * s
    return tau, w_c, d_new, w_out + alpha * s - alpha * h, -_velocity_at(w_h, alpha, h - tau, gamma), hops


@njit
def _rests(w_c, alpha, e, tau):
    """True when a particle meeting a floor (alpha < 0, m/s^2) at the normal velocity w_c <= 0 m/s
    tau s before the step's end comes to rest on it within the step (its bounce series e^k
    over, :func:`_wall_contact`): it is then held by the floor until the step's end."""
    return alpha < 0.0 and -2.0 * e * w_c <= -alpha * (1.0 - e) * tau


@njit
def _hold(i, normal_sign, d, alpha, e, support, hold_row, row):
    """Note particle i as held by a wall (box axis d, inward normal sign normal_sign, restitution
    e): support[i, :D] = -alpha along the normal (m/s^2, the wall's push that cancels its normal
    acceleration alpha < 0), support[i, D] = e, hold_row[i] = its bounce row (-1: none; a
    particle held by a particle q has -2 - q there, :func:`_rest_on`)."""
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
    """(takes, u_n): whether the wall holding particle k (support (N, D + 1), :func:`_hold`) of
    the pair (i, j) takes at once the part u_n (m/s) along its push of the velocity change dv
    nrm that a collision gives k at the contact, tau s before the step's end (dv m/s, nrm (D,)
    the unit line of centres), k staying held: (False, 0.0) when no wall holds k or the
    collision is no impact on it (not ``hit``).

    It does for an impact on k (``hit``, :func:`_held_root`) that does not take k off the wall
    (u_n <= 0 but for the round-off of the line of centres, LIFT_ROUND_OFF) and after which k
    would be back at rest on it within the step (:func:`_rests` of a contact at u_n): the end
    state is then that of the wall's bounce series, k at rest on it, and the wall's momentum
    gains -m u_n. Otherwise a hit k is released (:func:`_release`: pushed into the wall, it
    meets it again in the next pass); a partner merely resting on k (not ``hit``) is held by
    it (:func:`_rest_on`)."""
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
def _velocity_at(v_h, a, s, gamma):
    """Velocity (m/s, one component) s seconds after the step's middle, whose drift velocity is
    v_h m/s, under the constant acceleration a m/s^2 and linear friction gamma 1/s:
    v_h e^{-gamma s} + a (1 - e^{-gamma s}) / gamma (v_h + a s without friction), the motion the
    kicks integrate exactly. A contact's recorded speed and a collision's impulse use it, not
    the drift velocity: that one is off by about (gamma |v| + |a|) |s|, first order in dt."""
    if gamma > 0.0:
        return v_h * math.exp(-gamma * s) - a * math.expm1(-gamma * s) / gamma
    return v_h + a * s


@njit
def _last_flight(u, alpha, e, tau):
    """(time s since the last bounce, launch speed m/s, bounces k) at the end of tau s of bouncing on a
    floor (alpha < 0) from a launch at u m/s, each bounce giving back e times the arrival
    speed (0 < e <= 1), the series not over within tau: flight k lasts t0 e^k, t0 = 2 u / |alpha|,
    and ends at S_(k+1) = t0 (1 - e^(k+1)) / (1 - e) (t0 (k + 1) for e = 1); k bounces ended
    the flights 0..k-1."""
    t0 = -2.0 * u / alpha
    if e >= 1.0:
        k = int(math.floor(tau / t0))
    else:
        k = int(math.floor(math.log1p(-tau * (1.0 - e) / t0) / math.log(e)))
    if k < 0:
        k = 0
    for _ in range(4):  # round-off of the logarithms: S_k <= tau < S_(k+1)
        if k > 0 and _bounce_sum(t0, e, k) > tau:
            k -= 1
        elif _bounce_sum(t0, e, k + 1) <= tau:
            k += 1
    return tau - _bounce_sum(t0, e, k), u * e ** k, k


@njit
def _bounce_sum(t0, e, k):
    """Duration of the first k flights t0, t0 e, ..., t0 e^(k-1), s."""
    if e >= 1.0:
        return t0 * k
    return t0 * -math.expm1(k * math.log(e)) / (1.0 - e)


@njit
def _settle(tau, w_c, d_new, w_new, v_rec, hops, w_h, e, alpha, h):
    """A contact as :func:`_wall_contact` found it, settled: with none within the age (tau < 0,
    an invalid state) the particle is put on the wall, its normal velocity reversed (and
    tau = 0, a bounce now) if still moving out (w_c < 0), else kept (w_h). Returns (tau,
    w_c, d_new, w_new, v_rec, hops)."""
    if tau < 0.0:
        d_new = 0.0
        if w_c < 0.0:
            tau = 0.0
            w_new = -e * w_c - alpha * h
        else:
            w_new = w_h
    return tau, w_c, d_new, w_new, v_rec, hops


@njit
def _box_alpha(acc, i, d, sign, g):
    """Acceleration of particle i along the inward normal ``sign`` (+1 or -1) of a box wall of
    axis d, m/s^2: gravity (last axis) and the pair attraction acc (N, D) at the step's start
    (zeros without pair forces). Constant over the step, it makes kick-drift-kick's path
    the parabola :func:`_wall_contact` goes back along: without the attraction, a bounce of
    attracting bodies was met with the wrong speed, an energy error of order dt a bounce."""
    a = acc[i, d] - g if d == acc.shape[1] - 1 else acc[i, d]
    return sign * a


@njit
def _plane_alpha(acc, planes, i, p, g):
    """As :func:`_box_alpha` for extra plane p (planes (P, 2D+1): point, unit inward normal,
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

    Taken back to its contact (:func:`_wall_contact`), its normal velocity
    reversed and scaled by ``ew``, moved forward to the end of the step. An
    invalid state (no contact within its age) is put on the wall, its
    velocity reversed if still moving out. The bounce is recorded in bf (t,
    |v|, |v_perp| at contact, :func:`_velocity_at`) and bi (particle, RE_DIR) at row nb when
    ``want``, and so is each later bounce of a series of hops on a floor within the step
    (:func:`_hop_rows`). Returns (bf, bi, nb, bounces recorded, bounces folded into the last
    row of a series longer than MAX_HOP_ROWS). A particle that comes to rest on the wall is
    noted as held by it (:func:`_hold`).
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

    Same contact rule as the box walls (:func:`_wall_contact`); returns the bounces (1 and
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
def _excursion_tau(d_e, w_h, alpha, h, hr, gamma, age, e):
    """Time back (s) to the contact with a wall that a particle in front of it at the step's
    end (d_e >= 0, m) crossed and came back from within its age, or -1 for none (arguments as
    :func:`_wall_contact`). Only a path bending away from the wall (alpha > 0: a ceiling under
    gravity, a wall the attraction pulls away from) can: a parabola whose lowest point, tau* =
    w_e / alpha back, lies beyond it (d_e < w_e^2 / (2 alpha)); the contact is its earlier
    crossing. A ball thrown at a ceiling that it reaches within a step used to pass through it
    and fall back."""
    if alpha <= 0.0:
        return -1.0
    w_e = w_h + alpha * h
    if w_e <= 0.0 or w_e * w_e <= 2.0 * alpha * d_e:
        return -1.0
    return _wall_contact(d_e, w_h, alpha, h, hr, gamma, age, e)[0]


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
def _wall_scan(pos, vel, acc, radius, age, last, active, length, ew, g, h, hr, gamma, planes, k, cand_i, cand_j,
               cand_tau):
    """Write the first wall or plane crossing of each active particle from row k; returns the new count.

    Wall w is coded j = -1 - w: box walls w = 2 d + upper, planes w = 2 D + p
    (:func:`_earliest_wall`; a pass applies at most one contact a particle, its earliest).
    tau = time back to the contact, 0 for an invalid state (handled last).
    Rows beyond the arrays' size are counted, not written: the caller grows
    the arrays and scans again.
    """
    n = pos.shape[0]
    for i in range(n):
        if not active[i]:
            continue
        w, tau = _earliest_wall(i, pos, vel, acc, radius, age, last, length, ew, g, h, hr, gamma, planes, True)
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
def _walls_sweep(pos, vel, acc, radius, age, last, planes, length, ew, g, h, hr, gamma, t_end, want, bf, bi, nb,
                 counters, support, hold_row):
    """Safety net after the pass limit: every particle beyond a box wall bounces, earliest contact
    first, until it is inside the box (a particle crossing the box many times in one step gets
    every bounce); then once off each plane it is behind; then any centre still outside
    [R, L - R] (after SWEEP_BOUNCES bounces, or pushed out by a plane) is put on the wall.
    Returns (bf, bi, nb)."""
    n, dim = pos.shape
    for i in range(n):
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


# --- cell list -----------------------------------------------------------------
@njit
def _cell_list(radius, length, dim):
    """(largest radius, cells an axis for its diameter, and the cell list's arrays start,
    cell_of, order, unfilled) for the bodies of ``radius`` (N,) m in a box of side length."""
    n = radius.size
    rmax = 0.0
    for i in range(n):
        if radius[i] > rmax:
            rmax = radius[i]
    nc = _cells_per_axis(length, 2.0 * rmax, n, dim)
    return rmax, nc, np.empty(nc ** dim + 1, np.int64), np.empty(n, np.int64), np.empty(n, np.int64)


@njit
def _cells_per_axis(length, reach, n, dim):
    """Cells per axis: side at least ``reach`` m, at most about 32N cells in all.

    The cap bounds the O(cells) binning cost for dilute gases; 32 cells per
    particle keep piles (settled granular matter, 15 times denser than the
    average) cheap to search.
    """
    nc = int(length / reach) if reach > 0.0 else 1 << 30
    cap = int((32.0 * n + 64.0) ** (1.0 / dim) + 1e-9)
    if nc > cap:
        nc = cap
    if nc < 1:
        nc = 1
    return nc


@njit
def _cell_coord(x, length, nc):
    c = int(x / length * nc)
    if c < 0:
        return 0
    if c >= nc:
        return nc - 1
    return c


@njit
def _bin(pos, length, nc, cell_of, start, order):
    """Counting sort of particles into nc^D cells: particles of cell k are order[start[k]:start[k+1]]."""
    n, dim = pos.shape
    ncells = nc ** dim
    for k in range(ncells + 1):
        start[k] = 0
    for i in range(n):
        k = 0
        for d in range(dim - 1, -1, -1):
            k = k * nc + _cell_coord(pos[i, d], length, nc)
        cell_of[i] = k
        start[k + 1] += 1
    for k in range(ncells):
        start[k + 1] += start[k]
    fill = start[:ncells].copy()
    for i in range(n):
        k = cell_of[i]
        order[fill[k]] = i
        fill[k] += 1


@njit
def _contact_tau(pos, vel, i, j, sigma, age_max, swept, support):
    """(tau, c): how far back (s, >= 0) pair (i, j) touched within age_max, or -1 for no contact;
    c = |dr|^2 - sigma^2 at the step end, m^2 (< 0: overlapping).

    See the module docstring for the rule; always the cancellation-free root. When a wall
    holds one of the two (support (N, D + 1), :func:`_hold`) their relative path is not straight
    but the parabola dr - dv tau + A tau^2 / 2, A = support_j - support_i: the straight root
    is refined on it (:func:`_held_root`).
    """
    dim = pos.shape[1]
    a = 0.0
    b = 0.0
    c = -sigma * sigma
    for d in range(dim):
        dr = pos[j, d] - pos[i, d]
        dv = vel[j, d] - vel[i, d]
        a += dv * dv
        b += dr * dv
        c += dr * dr
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
    """Along axis d, for the pair (i, j) of :func:`_held_root`: the relative acceleration of
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
    contact is met on the drift lines, the partner held by the held one (:func:`_rest_on`)
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
def _detect(pos, vel, radius, age, active, all_active, speed, vmax, sigma_max, dt, length, nc,
            cell_of, start, order, swept, k, cand_i, cand_j, cand_tau, left, support):
    """Write the pairs in contact with at least one active particle from row k; returns the new count.

    With ``all_active`` (a step's first pass) also tallies in ``left`` (2,) the pairs the
    contact rule leaves alone although closer than (1 - OVERLAP_TOL) sigma (overlapping and
    separating: a contact missed in this step or before): left[0] their number, left[1] the
    smallest |dr| / sigma among them (the caller sets 0 and 1.0 first).

    Each pair is reported once; rows beyond the arrays' size are counted,
    not written (the caller grows the arrays and calls again). Search
    radius around an active particle i (m), over the cells it covers:

    * overlap detection: sigma_max (a pair of two active particles is
      examined from the lower index);
    * swept detection: a pair can have touched during the step only if
      |dr| <= sigma + (|v_i| + |v_j|) dt. When every particle is active
      (first pass) each pair is examined from its faster member, within
      sigma_max + 2 |v_i| dt; otherwise within sigma_max + (|v_i| + vmax) dt,
      a pair of two active particles still from the faster. So only the fast
      particles search far. ``speed`` (N,) |v| m/s, ``vmax`` its maximum.
    ``support`` (N, D + 1) m/s^2: the push of the wall holding each particle at rest (0: free),
    for the contacts of a held particle (:func:`_contact_tau`).
    """
    n, dim = pos.shape
    side = length / nc
    shrink = (1.0 - OVERLAP_TOL) * (1.0 - OVERLAP_TOL) - 1.0
    for i in range(n):
        if not active[i]:
            continue
        if swept:
            if all_active:
                rho = sigma_max + 2.0 * speed[i] * dt
            else:
                rho = sigma_max + (speed[i] + vmax) * dt
        else:
            rho = sigma_max
        m = int(math.ceil(rho * 1.000001 / side))
        if m < 1:
            m = 1
        c0 = _cell_coord(pos[i, 0], length, nc)
        c1 = _cell_coord(pos[i, 1], length, nc) if dim > 1 else 0
        c2 = _cell_coord(pos[i, 2], length, nc) if dim > 2 else 0
        m1 = m if dim > 1 else 0
        m2 = m if dim > 2 else 0
        lo0 = c0 - m if c0 - m > 0 else 0
        hi0 = c0 + m if c0 + m < nc else nc - 1
        for k2 in range(max(c2 - m2, 0), min(c2 + m2, nc - 1) + 1):
            for k1 in range(max(c1 - m1, 0), min(c1 + m1, nc - 1) + 1):
                # the cells along axis 0 are consecutive: one range of ``order``
                row = (k2 * nc + k1) * nc
                for q in range(start[row + lo0], start[row + hi0 + 1]):
                    j = order[q]
                    if j == i:
                        continue
                    if active[j]:
                        if swept:
                            if speed[j] > speed[i] or (speed[j] == speed[i] and j < i):
                                continue
                        elif j < i:
                            continue
                    amax = age[i] if age[i] < age[j] else age[j]
                    sigma = radius[i] + radius[j]
                    tau, c = _contact_tau(pos, vel, i, j, sigma, amax, swept, support)
                    if tau < 0.0:
                        if all_active and c < shrink * sigma * sigma:
                            left[0] += 1.0
                            ratio = math.sqrt(c / (sigma * sigma) + 1.0)
                            if ratio < left[1]:
                                left[1] = ratio
                        continue
                    if k < cand_i.shape[0]:
                        cand_i[k] = i
                        cand_j[k] = j
                        cand_tau[k] = tau
                    k += 1
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
def _rest_on(pos, vel, mass, acc, has_pair, g, support, hold_row, bf, i, j, nrm, vn, tau, e):
    """A free particle p resting on a held one k (pair (i, j), nrm (D,) the unit line of centres
    from i to j, vn < 0 m/s their relative normal drift velocity, contact tau s before the
    step's end, not an impact: :func:`_held_root`): the contact carries p's weight, so p is
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


@njit
def _collide(pos, vel, mass, radius, age, tlast, i, j, tau, t_end, e, tc, acc, has_pair, g, gamma, h, support,
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

    A particle a wall holds at rest (support (N, D + 1), :func:`_hold`) is there, at rest, at
    the contact, not on its drift line: when its partner hits it (:func:`_held_root`), the line
    of centres and the relative velocity are taken on the true paths (dr - dv tau + A tau^2 / 2
    and dv - A tau, A = support_j - support_i), and when the collision takes it off the wall it
    is released (:func:`_release`): it flies freely from the contact. A partner merely resting
    on it is held by it in turn (:func:`_rest_on`). When the collision leaves it on the wall (along it, or pushed
    into it: :func:`_wall_takes`) the wall takes the normal part of its velocity change and it
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


# --- one block of steps ------------------------------------------------------------
@njit
def _advance(nsteps, t0, k0, dt, pos, vel, acc, mass, radius, age, tlast, planes,
             length, g, gamma, G, eps2, e, ew, tc, max_passes, swept,
             want_b, want_c, bf, bi, nb, cf, ci, ncoll, flush_at,
             counters, clocks, virial, overlap, clock_id, nthreads, deadline):
    """Run up to ``nsteps`` steps of dt s (see the module docstring).

    Step s of the call ends at t0 + (k0 + s + 1) dt s: with t0 = 0 and k0 the index of the
    call's first step, every step's end time is the same whatever the calls' lengths, so a
    run cut into calls gives the same numbers bit for bit.

    pos, vel, acc (N, D) float64 are updated in place (acc holds the pair
    accelerations at the current positions); age, tlast (N,) scratch and TC
    times. Bounces go to bf (k, 3: t, |v|, |v_perp|) / bi (k, 2: particle,
    RE_DIR) from row nb, collisions to cf (k, 2: t, |J|) / ci (k, 2: i, j)
    from row ncoll; buffers grow as needed. counters (int64), clocks
    (float64, s) and virial (1,) accumulate. The pairs each step leaves overlapping (closer
    than (1 - OVERLAP_TOL) sigma and not resolved: see :func:`_detect`) are counted in the
    C_OVERLAP_* counters; overlap (2,) keeps the smallest |dr| / sigma seen and the time of
    the first step with one. clock_id: the clock_gettime
    clock (-1: no phase timing); nthreads: threads for the pair forces. Stops early (status FLUSH) once
    either buffer holds ``flush_at`` rows.

    Returns (status, steps_done, bf, bi, nb, cf, ci, ncoll).
    """
    n, dim = pos.shape
    has_pair = G > 0.0
    has_kick = has_pair or g > 0.0 or gamma > 0.0
    h = 0.5 * dt
    hr = math.expm1(gamma * h) / gamma if gamma > 0.0 else h  # (see _wall_contact)
    tbuf = np.zeros(2, np.int64)
    rmax, nc_max, start, cell_of, order = _cell_list(radius, length, dim)
    active = np.zeros(n, np.uint8)
    last = np.full(n, -1, np.int64)  # the wall each particle's path last bent at in this step (-1: none)
    support = np.zeros((n, dim + 1))  # a wall's push on the particles it holds at rest in this step, m/s^2, and
    # its restitution (_hold)
    hold_row = np.full(n, -1, np.int64)  # the bounce row of that rest (-1: none)
    done = np.zeros(n, np.uint8)
    speed = np.zeros(n)
    cand_i = np.empty(64, np.int64)
    cand_j = np.empty(64, np.int64)
    cand_tau = np.empty(64, np.float64)
    left = np.zeros(2)
    steps = 0
    status = DONE
    for s in range(nsteps):
        if nb >= flush_at or ncoll >= flush_at:
            status = FLUSH
            break
        t_end = t0 + (k0 + s + 1) * dt
        # --- push: half kick, drift
        c0 = _now(clock_id, tbuf)
        if has_kick:
            _kick(vel, acc, has_pair, g, gamma, h)
        _drift(pos, vel, dt, age)
        c1 = _now(clock_id, tbuf)
        clocks[T_PUSH] += c1 - c0
        # --- contact passes: walls, planes and pairs, earliest first
        for i in range(n):
            active[i] = 1
            last[i] = -1
            hold_row[i] = -1
            for d in range(dim):
                support[i, d] = 0.0
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
        counters[C_PASSES] += passes
        if passes > counters[C_MAX_PASSES]:
            counters[C_MAX_PASSES] = passes
        c3 = _now(clock_id, tbuf)
        clocks[T_COLLISIONS] += c3 - c1 - wall_time
        clocks[T_WALLS] += wall_time
        # --- forces at the new positions, second half kick
        if has_pair:
            _pair_acc(pos, mass, G, eps2, acc, nthreads)
            counters[C_PAIR_EVALS] += 1
        if has_kick:
            _kick(vel, acc, has_pair, g, gamma, h)
        clocks[T_PUSH] += _now(clock_id, tbuf) - c3
        steps += 1
        if clock_id >= 0 and steps < nsteps and _now(clock_id, tbuf) >= deadline:
            status = PAUSE
            break
    counters[C_STEPS] += steps
    return status, steps, bf, bi, nb, cf, ci, ncoll


@njit
def _overlaps_approaching(pos, vel, radius, length):
    """Number of pairs overlapping and approaching (cell list), for tests and checks."""
    n, dim = pos.shape
    rmax, nc, start, cell_of, order = _cell_list(radius, length, dim)
    _bin(pos, length, nc, cell_of, start, order)
    active = np.ones(n, np.uint8)
    age = np.full(n, np.inf)
    ci = np.empty(16, np.int64)
    cj = np.empty(16, np.int64)
    ct = np.empty(16, np.float64)
    return _detect(pos, vel, radius, age, active, True, np.zeros(n), 0.0, 2.0 * rmax, 0.0, length, nc, cell_of, start,
                   order, False, 0, ci, cj, ct, np.array([0.0, 1.0]), np.zeros((n, dim + 1)))
