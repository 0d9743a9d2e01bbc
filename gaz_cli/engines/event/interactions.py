"""What happens at contact: the hard-sphere pair time and collision rule.

The pair time is the stable root of physics.md section 9 (Bannerman et al., Comput.
Part. Mech. 1, 191, 2014): max(0, c / (-b + sqrt(b^2 - a c))) and only for b < 0, so
an overlapping pair that approaches collides at once and one that separates is left
alone.

The root is taken only for a hit (:func:`_contact_dt`): computed for every pair, the hit
chosen by a select, it left the cell scan waiting on the square root and the division; the
hit is one comparison, not two branches, and there is no second discriminant formula as a
sure-miss filter beside the stable one (measurements:
docs/explanation/engine_measurements.md#event-engine-interactions).
"""

from __future__ import annotations

import math

from gaz_cli.engines.event.intrinsics import _fma, _inline
from gaz_cli.engines.event.boundaries import _nearest
from gaz_cli.engines.event.layout import INF, OVERLAP_TOL, PR, PV

@_inline
def _cross(a, b, c, d):
    """a d - b c without cancellation (Kahan's algorithm with a fused multiply-add): within
    two roundings of the exact value however close a d and b c are."""
    w = b * c
    return _fma(a, d, -w) - _fma(b, c, -w)


@_inline
def _pair_dt(dx0, dx1, dx2, dv0, dv1, dv2, sig, D):
    """Time until |dx + dv t| = sig: max(0, c / (-b + sqrt(b^2 - a c))) if b < 0 and b^2 > a c, else inf.

    The stable root of physics.md section 9: an overlapping pair that
    approaches collides at once (0), one that separates never (inf).
    (:func:`_contact_dt` with a fixed sum of radii: its growth terms are compiled out.)
    """
    return _contact_dt(dx0, dx1, dx2, dv0, dv1, dv2, sig, 0.0, D)


@_inline
def _contact_dt(dx0, dx1, dx2, dv0, dv1, dv2, sig, s, D):
    """Time until |dx + dv t| = sig + s t, the contact of a pair whose sum of radii sig grows
    at the rate s >= 0 (0: hard spheres, every engine scan; > 0: placement's
    Lubachevsky-Stillinger growth); inf if never.

    The root of a t^2 + 2 b t + c = 0 with a = |dv|^2 - s^2, b = dx.dv - sig s,
    c = |dx|^2 - sig^2, in the stable form max(0, c / (-b + sqrt(b^2 - a c))): a pair
    that touches or overlaps while closing in (b < 0) collides at once (0), one that
    parts (b >= 0) never, unless it is outgrown (a < 0: the sum of radii grows faster
    than the pair can part), which meets it again, at the larger root when it overlaps
    now, at once when it cannot part at all. The discriminant is computed as
    a sig^2 - |dx x dv|^2 (Lagrange's identity), not b^2 - a c: for a grazing pair seen
    from afar b^2 and a c are both ~ a |dx|^2 and their difference loses 1e-16
    (|dx|/sig)^2 of itself, enough to turn a hit into a miss at 1000 sigma; the
    components of the cross product, each a difference of two products, are computed by
    :func:`_cross` without cancellation, so the discriminant is right to a few 1e-16 of
    a sig^2 at any distance (growth adds s (s |dx|^2 - 2 sig dx.dv)). For s = 0, a
    constant there (the engine's case: the growth's branches fold away), one branch: the
    root (a square root, a division) is taken only for a hit, b < 0 and disc > 0 tested
    as the one comparison max(b, -disc) < 0 (a hit is rare in a dilute cell scan; the
    sign of b alone is a coin toss that a branch predictor loses half the time, so the
    two tests must not be two branches). The figures:
    docs/explanation/engine_measurements.md#event-engine-interactions.
    """
    b = dx0 * dv0
    c = dx0 * dx0
    a = dv0 * dv0
    cross = 0.0
    if D > 1:
        b += dx1 * dv1
        c += dx1 * dx1
        a += dv1 * dv1
        cz = _cross(dx0, dx1, dv0, dv1)
        cross = cz * cz
    if D > 2:
        b += dx2 * dv2
        c += dx2 * dx2
        a += dv2 * dv2
        cx = _cross(dx1, dx2, dv1, dv2)
        cy = _cross(dx2, dx0, dv2, dv0)
        cross += cx * cx + cy * cy
    disc = a * (sig * sig) - cross
    if s != 0.0:
        disc += s * (s * c - 2.0 * b * sig)
        b -= s * sig
        a -= s * s
    c -= sig * sig
    hit = max(b, -disc) < 0.0  # b < 0 and disc > 0, one comparison: one branch
    if s == 0.0 and not hit:
        return INF  # most pairs of a cell scan: no root taken
    t = c / (math.sqrt(max(disc, 0.0)) - b)
    t = max(t, 0.0)
    if s != 0.0 and a < 0.0:
        if disc <= 0.0:
            return 0.0
        if b >= 0.0:
            return (b + math.sqrt(disc)) / -a
        return t
    return t if hit else INF


def pair_params(scene) -> tuple:
    """The interaction's parameters, as the kernels take them (``PP``): (restitution e, TC
    contact time tc). A tuple of floats: a compile-time type, passed by value through the
    scans and the collision rule at no cost. An interaction with more parameters (a square
    well's depth and width) adds them here, and its kernels read them."""
    return (float(scene.restitution), float(scene.tc))


def pair_reach(rmax: float, PP: tuple) -> float:
    """The largest centre distance at which two particles of radius at most rmax have a pair
    event (hard spheres: contact, 2 rmax): the cells and neighbour lists are sized on it."""
    return 2.0 * rmax


@_inline
def _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rk, rm, PP, D):
    """Time until the next event of a pair at separation dx, relative velocity dv (the
    other's minus this one's), radii rk and rm, parameters PP (:func:`pair_params`): the
    hard-core contact at rk + rm (inf if none). Every neighbour scan predicts pairs through
    this function, the one place that knows the pair's interaction."""
    return _pair_dt(dx0, dx1, dx2, dv0, dv1, dv2, rk + rm, D)


@_inline
def _earliest_two(tp, m, src, best, bj, src1, best2, bj2, src2):
    """The two earliest predictions of a scan after (tp, m, src) -- a pair time, its partner
    and where the partner was found -- given that tp is earlier than the second one: it
    takes the second place, or the first and moves the first down. Returns best, bj, src1,
    best2, bj2, src2; every neighbour scan keeps its two earliest partners through here."""
    if tp < best:
        return tp, m, src, best, bj, src1
    return best, bj, src1, tp, m, src


@_inline
def _pair_time_within(dx0, dx1, dx2, dv0, dv1, dv2, rk, rm, PP, D, horizon):
    """:func:`_pair_time`, or inf without the root when the pair cannot meet within
    ``horizon`` (inf: no bound).

    The cheap rejection of Smallenburg's code, in one comparison (one branch, rarely
    taken, where two tests gave LLVM a coin toss): a receding pair (b = dx.dv >= 0)
    never touches; an approaching one touches at s with 2 b s + |dv|^2 s^2 = sg^2 - r^2,
    so not within the horizon if 2 b horizon > sg^2 - r^2. b = 0 with an infinite
    horizon gives NaN, which max passes over: rejected, as it should be.
    """
    b = dx0 * dv0 + dx1 * dv1 + dx2 * dv2
    sg = rk + rm
    room = sg * sg - (dx0 * dx0 + dx1 * dx1 + dx2 * dx2)
    if max(b, 2.0 * b * horizon - room) < 0.0:
        return _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, rk, rm, PP, D)
    return INF


@_inline
def _collide(P, M, TL, k, j, t, L, PP, D, PER):
    """The hard-sphere collision rule for k and j, both rows at the contact time t.

    If the pair approaches, both velocities change by the impulse J = f dx, f = (1 + e)
    mu (dv.dx) / |dx|^2 along the line of centres dx (the nearest image when PER), with
    restitution e < 1 (PP = (e, tc), :func:`pair_params`) except within tc of either's last
    collision (the TC model: elastic then; TL holds each particle's last collision time,
    written only when e < 1). Returns
    (whether they collided, the impulse's magnitude (>= 0), the contact
    distance R_k + R_j, whether the pair was found overlapping beyond round-off: closer
    than sqrt(OVERLAP_TOL) (R_k + R_j), a missed collision that the tests watch).
    """
    dx0 = P[j, 0] - P[k, 0]
    dv0 = P[j, PV] - P[k, PV]
    dx1 = 0.0
    dv1 = 0.0
    dx2 = 0.0
    dv2 = 0.0
    if D > 1:
        dx1 = P[j, 1] - P[k, 1]
        dv1 = P[j, PV + 1] - P[k, PV + 1]
    if D > 2:
        dx2 = P[j, 2] - P[k, 2]
        dv2 = P[j, PV + 2] - P[k, PV + 2]
    if PER:
        dx0 = _nearest(dx0, L)
        if D > 1:
            dx1 = _nearest(dx1, L)
        if D > 2:
            dx2 = _nearest(dx2, L)
    bn = dx0 * dv0 + dx1 * dv1 + dx2 * dv2
    r2 = dx0 * dx0 + dx1 * dx1 + dx2 * dx2
    if not (bn < 0.0 and r2 > 0.0):
        return False, 0.0, 0.0, False
    sg = P[k, PR] + P[j, PR]
    overlap = r2 < OVERLAP_TOL * sg * sg
    mk = M[k]
    mj = M[j]
    e, tc = PP[0], PP[1]
    ee = 1.0
    if e < 1.0:
        if t - TL[k] >= tc and t - TL[j] >= tc:
            ee = e
        TL[k] = t
        TL[j] = t
    f = (1.0 + ee) * mk * mj / (mk + mj) * bn / r2
    fk = f / mk
    fj = f / mj
    P[k, PV] += fk * dx0
    P[j, PV] -= fj * dx0
    if D > 1:
        P[k, PV + 1] += fk * dx1
        P[j, PV + 1] -= fj * dx1
    if D > 2:
        P[k, PV + 2] += fk * dx2
        P[j, PV + 2] -= fj * dx2
    return True, -f * math.sqrt(r2), sg, overlap
