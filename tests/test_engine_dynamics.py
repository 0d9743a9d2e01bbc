"""gaz_cli.engines.event.dynamics, kernel by kernel: a row's flight against the exam's ``vol`` (and
the parabola under gravity), and the state of every row at a time."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import KERNEL_RTOL

from gaz_cli.engines import reference
from gaz_cli.engines.event.dynamics import _advance, _state_at
from gaz_cli.engines.event.layout import P_WIDTH, PT, PV


def _rows(rng, n, dim):
    P = np.zeros((n, P_WIDTH))
    P[:, :dim] = rng.uniform(0.0, 10.0, size=(n, dim))
    P[:, PV:PV + dim] = rng.normal(size=(n, dim))
    P[:, PT] = rng.uniform(0.0, 2.0, size=n)
    return P


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_free_flight_is_the_exams_vol(dim):
    """Each row advanced to t is vol's straight line over t - stamp, velocity kept, stamp t;
    a row already at t is left untouched."""
    rng = np.random.default_rng(dim)
    P = _rows(rng, 40, dim)
    before = P.copy()
    t = 3.5
    for k in range(40):
        _advance(P, k, t, 0.0, dim, False)
        p = [before[k, :dim].copy(), before[k, PV:PV + dim].copy()]
        reference.vol(p, t - before[k, PT])
        np.testing.assert_allclose(P[k, :dim], p[0], rtol=KERNEL_RTOL, atol=0)
        assert np.array_equal(P[k, PV:PV + dim], before[k, PV:PV + dim]) and P[k, PT] == t
    again = P.copy()
    for k in range(40):
        _advance(P, k, t, 0.0, dim, False)
    assert np.array_equal(P, again)


@pytest.mark.parametrize("dim", [2, 3])
def test_flight_under_gravity_is_the_parabola_and_state_at_agrees(dim):
    """Under gravity g along axis D-1: x + v dt - g dt^2 / 2 and v - g dt on that axis,
    straight lines on the others; _state_at gives the same positions and velocities
    without touching the rows."""
    rng = np.random.default_rng(10 + dim)
    g, t = 9.81, 2.75
    P = _rows(rng, 30, dim)
    before = P.copy()
    x = np.empty((30, dim))
    v = np.empty((30, dim))
    _state_at(P, t, g, dim, x, v)
    assert np.array_equal(P, before)
    for k in range(30):
        _advance(P, k, t, g, dim, True)
    dt = t - before[:, PT]
    want_x = before[:, :dim] + before[:, PV:PV + dim] * dt[:, None]
    want_x[:, -1] -= 0.5 * g * dt * dt
    want_v = before[:, PV:PV + dim].copy()
    want_v[:, -1] -= g * dt
    np.testing.assert_allclose(P[:, :dim], want_x, rtol=KERNEL_RTOL, atol=KERNEL_RTOL * 10)
    np.testing.assert_allclose(P[:, PV:PV + dim], want_v, rtol=KERNEL_RTOL, atol=KERNEL_RTOL * 10)
    np.testing.assert_allclose(x, P[:, :dim], rtol=KERNEL_RTOL, atol=KERNEL_RTOL * 10)
    np.testing.assert_allclose(v, P[:, PV:PV + dim], rtol=KERNEL_RTOL, atol=KERNEL_RTOL * 10)
