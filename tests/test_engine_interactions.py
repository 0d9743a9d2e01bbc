"""gaz_cli.engines.event.interactions, kernel by kernel, against the exam's twins in reference.py.

``_pair_dt`` (the hard-sphere pair time) against ``tc``, ``_collide`` (the collision rule)
against ``choc``; tolerance KERNEL_RTOL (conftest.py, with its error model).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli.engines import reference
from gaz_cli.engines.event.interactions import _collide, _pair_dt
from gaz_cli.engines.event.layout import P_WIDTH, PR, PT, PV

DRAWS = 200


def _approaching_pair(rng, dim, sigma, impact, near=1.1):
    """(dx, dv) of a pair near-3 sigma apart whose relative velocity misses the centre by
    ``impact`` times sigma (1D: head on)."""
    u = rng.normal(size=dim)
    u /= np.linalg.norm(u)
    dist = rng.uniform(near, 3.0) * sigma
    speed = rng.uniform(0.2, 3.0)
    if dim == 1:
        return dist * u, -speed * u
    w = rng.normal(size=dim)
    w -= np.dot(w, u) * u
    w /= np.linalg.norm(w)
    sin = impact * sigma / dist
    return dist * u, -speed * (math.sqrt(1.0 - sin * sin) * u + sin * w)


def _dt(dx, dv, sigma):
    dim = dx.size
    x = np.zeros(3)
    v = np.zeros(3)
    x[:dim], v[:dim] = dx, dv
    return _pair_dt(x[0], x[1], x[2], v[0], v[1], v[2], sigma, dim)


def _tc(dx, dv, sigma):
    p1 = [np.zeros(dx.size), np.zeros(dx.size)]
    p2 = [dx.copy(), dv.copy()]
    return reference.tc(p1, p2, sigma / 2.0)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_pair_time_is_the_exams_tc(dim):
    """Pairs that hit: the kernel's time is tc's within KERNEL_RTOL; pairs that miss, recede,
    or overlap while approaching: never (inf / None), never, at once (0) in both."""
    rng = np.random.default_rng(dim)
    sigma = 1.0
    for _ in range(DRAWS):
        dx, dv = _approaching_pair(rng, dim, sigma, rng.uniform(0.0, 0.8))
        want = _tc(dx, dv, sigma)
        assert want is not None
        assert _dt(dx, dv, sigma) == pytest.approx(want, rel=KERNEL_RTOL)
        # the same pair receding
        assert _dt(dx, -dv, sigma) == math.inf and _tc(dx, -dv, sigma) is None
        # overlapping and approaching: at once
        assert _dt(0.5 * sigma * dx / np.linalg.norm(dx), dv, sigma) == 0.0
        if dim > 1:
            dx, dv = _approaching_pair(rng, dim, sigma, rng.uniform(1.2, 2.0), near=2.6)
            assert _dt(dx, dv, sigma) == math.inf and _tc(dx, dv, sigma) is None


def _rows(x1, v1, x2, v2, r1, r2, dim):
    P = np.zeros((2, P_WIDTH))
    P[0, :dim], P[0, PV:PV + dim], P[0, PR] = x1, v1, r1
    P[1, :dim], P[1, PV:PV + dim], P[1, PR] = x2, v2, r2
    P[:, PT] = 0.0
    return P


def _contact(rng, dim, r1, r2):
    """Two particles in contact (centres R1 + R2 apart along a random n), approaching."""
    n = rng.normal(size=dim)
    n /= np.linalg.norm(n)
    x1 = rng.uniform(2.0, 3.0, size=dim)
    x2 = x1 + (r1 + r2) * n
    v1 = rng.normal(size=dim)
    v2 = rng.normal(size=dim)
    if np.dot(v2 - v1, n) > 0:
        v1, v2 = v2, v1
    return x1, v1, x2, v2


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_collision_rule_is_the_exams_choc(dim):
    """At restitution 1, unequal masses and radii: the new velocities are choc's within
    KERNEL_RTOL (of the speeds), the impulse is choc's momentum transfer, and the pair is
    not flagged as overlapping."""
    rng = np.random.default_rng(10 + dim)
    for _ in range(DRAWS):
        r1, r2 = rng.uniform(0.2, 0.6, size=2)
        m = rng.uniform(0.5, 4.0, size=2)
        x1, v1, x2, v2 = _contact(rng, dim, r1, r2)
        P = _rows(x1, v1, x2, v2, r1, r2, dim)
        TL = np.full(2, -np.inf)
        hit, jmag, sg, overlap = _collide(P, m, TL, 0, 1, 0.0, 100.0, (1.0, 0.0), dim,
                                          False)
        p1, p2 = [x1.copy(), v1.copy()], [x2.copy(), v2.copy()]
        reference.choc(p1, p2, masses=m)
        scale = np.abs(np.concatenate([v1, v2])).max()
        assert hit and not overlap and sg == r1 + r2
        np.testing.assert_allclose(P[0, PV:PV + dim], p1[1], rtol=0, atol=KERNEL_RTOL * scale)
        np.testing.assert_allclose(P[1, PV:PV + dim], p2[1], rtol=0, atol=KERNEL_RTOL * scale)
        assert abs(jmag) == pytest.approx(m[0] * np.linalg.norm(p1[1] - v1), rel=KERNEL_RTOL)
        assert jmag >= 0.0


def test_restitution_and_the_tc_model():
    """Restitution e scales the normal relative velocity by -e (choc's is -1), except within
    tc of either particle's last collision (the TC model: elastic); a receding pair is left
    alone; a pair closer than its contact distance is flagged."""
    rng = np.random.default_rng(7)
    dim, e = 3, 0.6
    x1, v1, x2, v2 = _contact(rng, dim, 0.5, 0.5)
    n = (x2 - x1) / np.linalg.norm(x2 - x1)
    for last, want in ((-1.0, e), (9.99, 1.0)):
        P = _rows(x1, v1, x2, v2, 0.5, 0.5, dim)
        TL = np.array([last, -1.0])
        hit, _, _, _ = _collide(P, np.ones(2), TL, 0, 1, 10.0, 100.0, (e, 0.1), dim, False)
        vn0 = np.dot(v2 - v1, n)
        vn1 = np.dot(P[1, PV:PV + dim] - P[0, PV:PV + dim], n)
        assert hit and vn1 == pytest.approx(-want * vn0, rel=1e-12)
        assert np.all(TL == 10.0)
    P = _rows(x1, v2, x2, v1, 0.5, 0.5, dim)  # receding
    assert not _collide(P, np.ones(2), np.zeros(2), 0, 1, 0.0, 100.0, (1.0, 0.0), dim,
                        False)[0]
    P = _rows(x1, v1, x1 + 0.9 * (x2 - x1), v2, 0.5, 0.5, dim)
    assert _collide(P, np.ones(2), np.zeros(2), 0, 1, 0.0, 100.0, (1.0, 0.0), dim,
                    False)[3]


def test_collision_across_a_periodic_face_uses_the_nearest_image():
    """Two disks touching across the face x = 0 of a periodic box of side 10 collide as choc
    says for the nearest images."""
    L = 10.0
    x1, v1 = np.array([0.2, 5.0]), np.array([-1.0, 0.3])
    x2, v2 = np.array([L - 0.2, 5.0]), np.array([1.0, -0.1])
    P = _rows(x1, v1, x2, v2, 0.2, 0.2, 2)
    hit, _, _, _ = _collide(P, np.ones(2), np.zeros(2), 0, 1, 0.0, L, (1.0, 0.0), 2, True)
    p1, p2 = [x1.copy(), v1.copy()], [x2 - [L, 0.0], v2.copy()]
    reference.choc(p1, p2)
    assert hit
    np.testing.assert_allclose(P[0, PV:PV + 2], p1[1], rtol=0, atol=KERNEL_RTOL)
    np.testing.assert_allclose(P[1, PV:PV + 2], p2[1], rtol=0, atol=KERNEL_RTOL)


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_time_within_a_horizon_is_the_pair_time_or_inf(dim):
    """The scans' cheap rejection (_pair_time_within) changes no answer: the pair time when
    contact comes within the horizon, inf when it comes after, when the pair recedes or
    misses; an overlapping approaching pair touches at once whatever the horizon."""
    from gaz_cli.engines.event.interactions import _pair_time_within

    rng = np.random.default_rng(5)
    sigma, pp = 1.0, (1.0, 0.0)
    for _ in range(DRAWS):
        dx, dv = _approaching_pair(rng, dim, sigma, rng.uniform(0.0, 1.05))  # > 1: a miss
        x, v = np.zeros(3), np.zeros(3)
        x[:dim], v[:dim] = dx, dv
        want = _pair_dt(*x, *v, sigma, dim)
        finite = math.isfinite(want)
        for horizon in (math.inf, 1e3, 0.5 * want if finite else 1.0, 1.0001 * want if finite else 2.0):
            got = _pair_time_within(*x, *v, 0.5 * sigma, 0.5 * sigma, pp, dim, horizon)
            assert got == (want if want <= horizon else math.inf)
        assert _pair_time_within(*x, *(-v), 0.5, 0.5, pp, dim, math.inf) == math.inf  # receding
    x, v = np.zeros(3), np.zeros(3)
    x[0], v[0] = 0.9 * sigma, -1.0  # overlapping, approaching
    assert _pair_time_within(*x, *v, 0.5, 0.5, pp, dim, 1e-30) == 0.0
