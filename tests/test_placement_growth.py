"""Placement's Lubachevsky-Stillinger growth on the engine's kernels, piece by piece.

The growth's pair time is the engine's contact root with a growing sum of radii
(``interactions._contact_dt`` with s > 0), checked against the definition solved in
50-digit decimals; its collision rule (``placement.growth._ls_collide``) against the growing
frame's elastic bounce; the whole growth on the engine's cells when a cell overflows and
is widened mid-run.
"""

from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli import placement
from gaz_cli.engines.event.interactions import _contact_dt
from gaz_cli.engines.event.layout import P_WIDTH, PR, PV

DRAWS = 200


def _contact_reference(dx, dv, sig, s):
    """First time t >= 0 at which |dx + dv t| = sig + s t with the pair closing in (in the
    growing sense), from the definition: the quadratic (|dv|^2 - s^2) t^2 + 2 (dx.dv - sig s) t
    + |dx|^2 - sig^2 = 0 solved in 50-digit decimals (the floats are exact there). Apart: the
    smallest positive root; overlapping: now if closing in, else the larger root if the pair
    is outgrown (it parts, then touches again), else never (inf)."""
    getcontext().prec = 50
    D = [Decimal(float(x)) for x in dx]
    V = [Decimal(float(x)) for x in dv]
    sg, ss = Decimal(float(sig)), Decimal(float(s))
    a = sum(v * v for v in V) - ss * ss
    b = sum(x * v for x, v in zip(D, V)) - sg * ss
    c = sum(x * x for x in D) - sg * sg
    disc = b * b - a * c
    if c < 0:
        if b < 0:
            return 0.0
        if a < 0:
            return float((-b - disc.sqrt()) / a) if disc > 0 else 0.0
        return math.inf
    if disc < 0 or a == 0:
        return math.inf
    roots = sorted(r for r in ((-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a) if r >= 0)
    return float(roots[0]) if roots else math.inf


def _kernel(dx, dv, sig, s):
    x = np.zeros(3)
    v = np.zeros(3)
    x[:dx.size], v[:dv.size] = dx, dv
    return _contact_dt(x[0], x[1], x[2], v[0], v[1], v[2], sig, s, dx.size)


@pytest.mark.parametrize("dim", [2, 3])
def test_growing_contact_time_is_the_definitions_root(dim):
    """Pairs 1.1 to 3 sigma apart with random velocities and growth speeds (approaching,
    receding, outgrown), and overlapping pairs (closing in, parting):
    the kernel's time is the definition's within KERNEL_RTOL (its error model: the same
    closed form in another order; the draws keep the root's condition number below 2 by
    asking for a clear hit or a clear miss), inf and 0 exactly where the definition says."""
    rng = np.random.default_rng(40 + dim)
    sigma = 1.0
    seen = {"hit": 0, "outgrown": 0, "never": 0, "now": 0, "parts": 0}
    for _ in range(DRAWS):
        u = rng.normal(size=dim)
        u /= np.linalg.norm(u)
        dist = rng.uniform(1.1, 3.0) * sigma if rng.random() < 0.7 else rng.uniform(0.5, 0.95)
        dx = dist * u
        dv = rng.normal(size=dim) * rng.uniform(0.2, 3.0)
        s = rng.uniform(0.0, 2.0)
        want = _contact_reference(dx, dv, sigma, s)
        got = _kernel(dx, dv, sigma, s)
        a = dv @ dv - s * s
        b = dx @ dv - sigma * s
        c = dx @ dx - sigma * sigma
        disc = b * b - a * c
        if c > 0 and disc > 0 and abs(disc) < 0.01 * b * b:
            continue  # a graze: the root's condition number is large, the test is not about it
        assert got == pytest.approx(want, rel=KERNEL_RTOL, abs=0.0), (dx, dv, s)
        if c < 0:
            # (parting but outgrown cannot happen: |dx| < sig and |dv| < s give b < 0)
            seen["now" if b < 0 else "parts"] += 1
        elif math.isfinite(want):
            seen["outgrown" if b >= 0 else "hit"] += 1
        else:
            seen["never"] += 1
    assert min(seen.values()) > 0, seen  # every case drawn


def test_growth_collision_is_elastic_in_the_growing_frame():
    """A pair in contact closing in slower than its sum of radii grows (un < s) leaves with
    un' = 2 s - un along the line of centres; the tangential velocities and the total
    momentum are kept (equal masses)."""
    rng = np.random.default_rng(3)
    dim, gamma = 3, 0.1
    for _ in range(DRAWS):
        r = rng.uniform(0.2, 0.5, size=2)
        n = rng.normal(size=dim)
        n /= np.linalg.norm(n)
        P = np.zeros((2, P_WIDTH))
        P[0, :dim] = rng.uniform(2.0, 3.0, size=dim)
        P[1, :dim] = P[0, :dim] + (r[0] + r[1]) * gamma * 4.0 * n  # radii R gamma t at t = 4
        P[:, PV:PV + dim] = rng.normal(size=(2, dim))
        P[:, PR] = r
        v0 = P[:, PV:PV + dim].copy()
        s = (r[0] + r[1]) * gamma
        un = (v0[1] - v0[0]) @ n
        placement.growth._ls_collide(P, 0, 1, 100.0, False, gamma, dim)
        v1 = P[:, PV:PV + dim]
        scale = np.abs(v0).max() + s
        np.testing.assert_allclose(v1.sum(axis=0), v0.sum(axis=0), rtol=0, atol=KERNEL_RTOL * scale)
        want = 2.0 * s - un if un < s else un
        assert (v1[1] - v1[0]) @ n == pytest.approx(want, rel=0, abs=KERNEL_RTOL * scale)
        tangential = (v1[1] - v1[0]) - ((v1[1] - v1[0]) @ n) * n
        np.testing.assert_allclose(tangential, (v0[1] - v0[0]) - un * n, rtol=0,
                                   atol=KERNEL_RTOL * scale)


def test_growth_widens_a_full_cell():
    """A few large spheres among many small ones (radii 0.5 and 0.15): cells one large
    diameter wide hold dozens of small ones, more as they wander; this draw's growth widens
    the cell table once, when a crossing would overflow a cell, and ends valid (inside,
    apart) at the target packing."""
    rng = np.random.default_rng(8)
    radii = np.where(rng.random(300) < 0.05, 0.5, 0.15)
    L = (np.sum(4.0 / 3.0 * math.pi * radii ** 3) / 0.30) ** (1 / 3)
    x = placement.grow(3, radii, L, np.random.default_rng(1), periodic=True)
    assert placement.first_overlap(x, radii, L, True) == -1
    assert np.all((x >= 0) & (x < L))


def test_growth_stopped_at_a_full_cell_goes_on_as_if_the_cell_had_room(monkeypatch):
    """The growth kernel returns at a crossing into a full cell (CELL_FULL) and, its table
    widened by the engine's :func:`wider`, goes on where it stopped: the same positions, bit
    for bit, as a growth whose table had room from the start (widened 3 times up front)."""
    from gaz_cli.engines.event.neighbours.cells import wider

    rng = np.random.default_rng(8)
    radii = np.where(rng.random(300) < 0.05, 0.5, 0.15)
    L = (np.sum(4.0 / 3.0 * math.pi * radii ** 3) / 0.30) ** (1 / 3)
    widened = []

    def counted(table):
        widened.append(table.shape)
        return wider(table)

    monkeypatch.setattr(placement.growth, "wider", counted)
    x = placement.grow(3, radii, L, np.random.default_rng(5), periodic=True)
    assert widened  # this draw fills a cell after 874 events (a rescale at 600 before)
    table = placement.growth._cell_table
    monkeypatch.setattr(placement.growth, "_cell_table", lambda *a: wider(wider(wider(table(*a)))))
    widened.clear()
    roomy = placement.grow(3, radii, L, np.random.default_rng(5), periodic=True)
    assert not widened and np.array_equal(x, roomy)
