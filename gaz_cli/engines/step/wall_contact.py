"""One particle meeting one flat wall along its normal: the contact time on the step's
parabola, the bounce, the hops of a series on a floor and rest (box walls and extra planes
share it: :mod:`.walls`).
"""

from __future__ import annotations

import math

from gaz_cli.numba_config import njit


@njit
def _wall_contact(d_e, w_h, alpha, h, hr, gamma, age, e):
    """Contact of one particle with one wall, along the wall's inward normal.

    d_e (m): signed distance of the centre from its contact position at the
    end of the step (< 0: beyond the wall); w_h (m/s): normal drift velocity;
    alpha (m/s^2): normal acceleration, gravity and the pair attraction at
    the step's start (:func:`gaz_cli.engines.step.walls._box_alpha`; 0 for a wall parallel to gravity
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
    :func:`gaz_cli.engines.step.walls._hop_rows`). v_rec is the normal speed at the contact (|w_c|,
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
    over, :func:`gaz_cli.engines.step.wall_contact._wall_contact`): it is then held by the floor until the step's end."""
    return alpha < 0.0 and -2.0 * e * w_c <= -alpha * (1.0 - e) * tau


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
    """A contact as :func:`gaz_cli.engines.step.wall_contact._wall_contact` found it, settled: with none within the age (tau < 0,
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
def _excursion_tau(d_e, w_h, alpha, h, hr, gamma, age, e):
    """Time back (s) to the contact with a wall that a particle in front of it at the step's
    end (d_e >= 0, m) crossed and came back from within its age, or -1 for none (arguments as
    :func:`gaz_cli.engines.step.wall_contact._wall_contact`). Only a path bending away from the wall (alpha > 0: a ceiling under
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
