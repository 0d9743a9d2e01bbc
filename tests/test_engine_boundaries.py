"""gaz_cli.engines.event.boundaries, kernel by kernel: the wall time against the exam's ``tr``, the
bounce against ``rebond``, the periodic wrap and nearest image against their definitions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli.engines import reference
from gaz_cli.engines.event.boundaries import _bounce, _crossing, _nearest, _wrap
from gaz_cli.engines.event.layout import I_WIDTH, P_WIDTH, PR, PT, PV

L = 10.0


def _row(x, v, r, t0=0.0):
    dim = len(x)
    P = np.zeros((1, P_WIDTH))
    P[0, :dim], P[0, PV:PV + dim], P[0, PR], P[0, PT] = x, v, r, t0
    return P


def _wall_time(P, dim, g=0.0):
    """(absolute time, code) of the next wall bounce of a lone particle (one cell, walls)."""
    I = np.zeros((1, I_WIDTH), dtype=np.int32)
    edges = np.array([0.0, L])
    return _crossing(P, I, edges, 0, 1, 1, L, g, dim, False, g > 0.0, False, False)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_wall_time_is_the_exams_tr(dim):
    """A particle anywhere in the box (at least 0.01 L from the walls it heads for): the
    kernel's time and axis are tr's, the time within KERNEL_RTOL, its code says a wall,
    and the direction is that of the velocity along the axis."""
    rng = np.random.default_rng(20 + dim)
    for _ in range(300):
        r = rng.uniform(0.0, 0.5)
        x = rng.uniform(r + 0.1, L - r - 0.1, size=dim)
        v = rng.normal(size=dim)
        t0 = rng.uniform(0.0, 5.0)
        t, code = _wall_time(_row(x, v, r, t0), dim)
        dt, d = reference.tr([x.copy(), v.copy()], r, L)
        assert code >> 2 == d and code & 1 == 1
        assert bool(code & 2) == (v[d] > 0)
        assert t - t0 == pytest.approx(dt, rel=KERNEL_RTOL, abs=KERNEL_RTOL * t0)


def test_a_particle_past_a_wall_and_moving_out_bounces_at_once_and_at_rest_never():
    """tr clips a negative time to 0; so does the kernel. A particle at rest has no wall
    event (tr: None, kernel: inf)."""
    t, code = _wall_time(_row([L + 0.1, 5.0], [2.0, 0.0], 0.5, 3.0), 2)
    assert t == 3.0 and code == 0 * 4 + 2 + 1
    assert reference.tr([np.array([L + 0.1, 5.0]), np.array([2.0, 0.0])], 0.5, L)[0] == 0.0
    t, code = _wall_time(_row([5.0, 5.0], [0.0, 0.0], 0.5), 2)
    assert t == math.inf and code == -1
    assert reference.tr([np.array([5.0, 5.0]), np.zeros(2)], 0.5, L) is None


def test_wall_time_under_gravity_is_the_root_of_the_parabola():
    """Along the gravity axis the time to the floor (or the ceiling) solves
    y + v t - g t^2 / 2 = R (or L - R), checked by putting it back in the parabola."""
    rng = np.random.default_rng(5)
    g, r = 9.81, 0.3
    for _ in range(200):
        y = rng.uniform(1.0, L - 1.0)
        v = rng.normal(scale=8.0)
        t, code = _wall_time(_row([5.0, y], [0.0, v], r), 2, g)
        assert code >> 2 == 1 and code & 1
        wall = L - r if code & 2 else r
        y_hit = y + v * t - 0.5 * g * t * t
        assert y_hit == pytest.approx(wall, abs=KERNEL_RTOL * (L + abs(v) * t + g * t * t))
        # and no wall before: the top of the arc (if it comes first) stays below the ceiling
        if not code & 2 and v > 0:
            assert y + v * v / (2 * g) < L - r


@pytest.mark.parametrize("d, up", [(0, False), (1, True), (2, True)])
def test_bounce_is_the_exams_rebond_with_the_centre_on_the_wall(d, up):
    """The velocity along d changes sign, the others are kept (rebond); the centre is put
    exactly on the wall plane (R or L - R)."""
    x, v, r = np.array([0.49, 9.6, 9.55]), np.array([-1.0, 2.0, 3.0]), 0.45
    P = _row(x, v, r)
    _bounce(P, 0, d, up, L)
    p = [x.copy(), v.copy()]
    reference.rebond(p, d)
    assert np.array_equal(P[0, PV:PV + 3], p[1])
    assert P[0, d] == (L - r if up else r)
    assert np.array_equal(np.delete(P[0, :3], d), np.delete(x, d))


def test_wrap_and_nearest_image():
    """_wrap puts every coordinate in [0, L) (x - L floor(x / L)) and counts the box lengths
    it took off in the images (x = wrapped + images L: the H5MD trajectory's unwrapped
    position); _nearest gives the image of a separation within [-L/2, L/2]."""
    rng = np.random.default_rng(3)
    x = rng.uniform(-3 * L, 4 * L, size=(50, 3))
    P = np.zeros((50, P_WIDTH))
    P[:, :3] = x
    images = np.zeros((50, 3), dtype=np.int64)
    images[::2] = 5  # (counts add to what a particle had)
    for k in range(50):
        _wrap(P, images, k, L, 3)
    assert np.all((P[:, :3] >= 0.0) & (P[:, :3] < L))
    np.testing.assert_allclose(P[:, :3], np.mod(x, L), rtol=0, atol=KERNEL_RTOL * 4 * L)
    images[::2] -= 5
    np.testing.assert_array_equal(images, np.floor(x / L).astype(np.int64))
    for dx in rng.uniform(-3 * L, 3 * L, size=100):
        n = _nearest(dx, L)
        assert abs(n) <= 0.5 * L * (1 + KERNEL_RTOL)
        assert (dx - n) / L == pytest.approx(round((dx - n) / L), abs=1e-9)
