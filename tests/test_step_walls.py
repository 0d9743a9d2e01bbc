"""The time-stepped engine's walls: every bounce its own row, whatever dt."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaz_cli.engines import step as stepper
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.model.species import Species
from gaz_cli.engines.step import codes

BALL = Species("ball", 1.0, 0.01)
G = 9.81

ROUND_OFF = 1e-9
"""Bounce times and speeds below come from closed forms evaluated in another order than the
kernel's (sums of a geometric series, square roots): agreement to round-off, a few eps times
the number of terms; 1e-9 relative leaves room and refuses any bounce off by a flight."""


def dropped_ball(e, dt, duration, height=0.2, plane=False):
    """A ball dropped from ``height`` m above the floor (the box's, or an extra plane 0.1 m up
    with ``plane``), floor restitution e, gravity G."""
    r = BALL.radius
    floor = 0.1 if plane else 0.0
    kw = {"planes": (((0.5, floor), (0.0, 1.0), e),)} if plane else {"wall_restitution": e}
    sc = Scene(dim=2, length=1.0, duration=duration, components=((BALL, 1),), seed=1, engine="step",
               dt=dt, gravity=G, **kw)
    st = State(np.array([[0.5, floor + r + height]]), np.array([[0.0, 0.0]]), sc.kinds())
    return sc, st


def exact_bounces(e, duration, height=0.2):
    """(times s, |v_perp| m/s) of the floor bounces of the dropped ball up to ``duration``:
    the first at t1 = sqrt(2 h / g) at g t1, then bounce k at t1 + t0 (1 - e^k) / (1 - e)
    (t1 + k t0 for e = 1), t0 = 2 e g t1 / g, at e^k g t1."""
    t1 = math.sqrt(2 * height / G)
    u = e * G * t1
    t0 = 2 * u / G
    times, speeds = [t1], [G * t1]
    k = 1
    while True:
        t = t1 + (t0 * k if e == 1 else t0 * (1 - e ** k) / (1 - e))
        if t > duration:
            return np.array(times), np.array(speeds)
        times.append(t)
        speeds.append(u * e ** (k - 1))
        k += 1


@pytest.mark.parametrize("e", [1.0, 0.8])
@pytest.mark.parametrize("dt", [1e-3, 0.25])
def test_every_bounce_of_a_ball_hopping_on_the_floor_has_its_own_row(e, dt):
    """A ball dropped on the floor: one row per bounce at its exact time and speed, whatever dt.

    Before, the bounces after the first within one step were folded into the first's row (its
    |v_perp| their sum): at dt = 0.25 s, e = 0.8, 5 rows for the 8 bounces of 1.5 s (the
    momentum right, the count low). Exact expectation: the closed form of exact_bounces (the
    step engine meets a floor on the exact parabola, so no dt error enters)."""
    duration = 1.5  # e = 0.8: the hops shorten to 0.05 s, several within a step of 0.25 s
    sc, st = dropped_ball(e, dt, duration)
    rec = MemoryRecorder()
    rs = stepper.run(sc, st, rec)
    b = rec.bounces()
    times, speeds = exact_bounces(e, duration)
    assert rs.wall_bounces == b["t"].size == times.size == (4 if e == 1 else 8)
    assert np.all(b["wall"] == -2) and rs.extras["folded_bounces"] == 0
    np.testing.assert_allclose(b["t"], times, rtol=ROUND_OFF)
    np.testing.assert_allclose(b["vperp"], speeds, rtol=ROUND_OFF)
    np.testing.assert_allclose(b["speed"], speeds, rtol=ROUND_OFF)


def test_hops_on_an_extra_plane_are_counted_one_by_one():
    """The same drop on an extra plane (no rows: planes have no RE_DIR): plane_bounces counts
    each bounce (it counted one per step)."""
    sc, st = dropped_ball(0.8, 0.25, 1.5, plane=True)
    rs = stepper.run(sc, st, MemoryRecorder())
    assert rs.extras["plane_bounces"] == exact_bounces(0.8, 1.5)[0].size == 8
    assert rs.wall_bounces == 0


def test_a_series_of_hops_longer_than_the_row_limit_folds_the_rest_into_its_last_row():
    """A ball leaving an elastic floor at 1 micrometre per second hops every t0 = 2e-6 / g s,
    about 5000 times in a step of 1 ms: the first MAX_HOP_ROWS bounces after the contact get a
    row each, the last row carries the rest (folded_bounces), and the rows' momentum
    2 m sum |v_perp| is the floor's, m g T (from and back to the same launch speed, the ball
    ends where it started its flight or within one hop of it).

    Tolerance: the contact is found back on the step's parabola from the end position y ~ R,
    rounded to eps R; a hop of u reaches u^2 / 2g, so the launch speed found carries a relative
    error about g eps R / u^2 (2e-5 here; 1.8e-7 measured), and so do t0 and the momentum."""
    u, dt = 1e-6, 1e-3
    t0 = 2 * u / G
    hop_round_off = 10 * G * np.finfo(float).eps * BALL.radius / u ** 2
    sc = Scene(dim=2, length=1.0, duration=dt, components=((BALL, 1),), seed=1, engine="step", dt=dt,
               gravity=G)
    st = State(np.array([[0.5, BALL.radius]]), np.array([[0.0, u]]), sc.kinds())
    rec = MemoryRecorder()
    rs = stepper.run(sc, st, rec)
    b = rec.bounces()
    bounces = math.floor(dt / t0)
    assert b["t"].size == rs.wall_bounces == codes.MAX_HOP_ROWS + 1
    assert rs.extras["folded_bounces"] == bounces - b["t"].size
    np.testing.assert_allclose(b["t"], t0 * np.arange(1, b["t"].size + 1), rtol=hop_round_off)
    vy = rs.final.velocities[0, 1]
    np.testing.assert_allclose(2 * BALL.mass * np.sum(b["vperp"]), BALL.mass * (G * dt + vy - u),
                               rtol=hop_round_off)


def test_a_side_wall_bounce_under_gravity_records_the_speed_at_the_contact():
    """Thrown sideways under gravity, the ball meets the wall x = L - R at t_c = (L - R - x0) / vx;
    the row's |v| is sqrt(vx^2 + (g t_c)^2), the speed at the contact.

    Before, the vertical component was the step's drift velocity (that of the step's middle),
    off by g (t_c - t_mid): at dt = 0.01 s, |v| 3.9312 m/s for 3.9101. Kick-drift-kick is exact
    under uniform gravity and the wall is met on a straight line in x: round-off only."""
    g, x0, vx, dt = 9.81, 0.305, 2.0, 0.01
    sc = Scene(dim=2, length=1.0, duration=0.4, components=((BALL, 1),), seed=1, engine="step", dt=dt,
               gravity=g)
    st = State(np.array([[x0, 0.9]]), np.array([[vx, 0.0]]), sc.kinds())
    rec = MemoryRecorder()
    stepper.run(sc, st, rec)
    b = rec.bounces()
    t_c = (1.0 - BALL.radius - x0) / vx  # a quarter of a step before the step's middle
    assert b["t"].size == 1 and b["wall"][0] == 1
    assert b["t"][0] == pytest.approx(t_c, rel=ROUND_OFF)
    assert b["vperp"][0] == pytest.approx(vx, rel=ROUND_OFF)
    assert b["speed"][0] == pytest.approx(math.hypot(vx, g * t_c), rel=ROUND_OFF)


def test_a_bounce_under_friction_records_the_speed_at_the_contact_to_second_order():
    """Friction gamma alone, in 1D: v = v0 - gamma (x - x0) along the path, so the ball meets the
    wall x = L - R at v_c = v0 - gamma (L - R - x0), whatever the time.

    Before, the row's |v_perp| was the drift velocity (the step's middle), off by about
    gamma |v| |t_c - t_mid|, first order: 6.2e-3 m/s at dt = 4e-3 s, 2.9e-3 at dt/2. Error model
    now (second order): the scheme's velocity at a contact is exact at the scheme's position,
    which is off the exact path by the chord of a step, gamma v dt^2 / 8, plus kick-drift-kick's
    accumulated error, v gamma^2 t dt^2 / 24; |delta v_c| = gamma |delta x| at most. Checked at
    dt and dt/2 (measured 4.9e-6 and 1.5e-6 m/s, bounds 2.9e-5 and 7.3e-6)."""
    gamma, x0, v0 = 2.0, 0.3, 3.0
    span = 1.0 - BALL.radius - x0
    t_c = -math.log1p(-gamma * span / v0) / gamma
    v_c = v0 - gamma * span
    for dt in (4e-3, 2e-3):
        sc = Scene(dim=1, length=1.0, duration=0.4, components=((BALL, 1),), seed=1, engine="step", dt=dt,
                   drag=gamma)
        rec = MemoryRecorder()
        stepper.run(sc, State(np.array([[x0]]), np.array([[v0]]), sc.kinds()), rec)
        b = rec.bounces()
        assert b["t"].size == 1
        bound = gamma * v0 * (gamma * gamma * t_c / 24 + gamma / 8) * dt * dt
        assert abs(b["vperp"][0] - v_c) <= bound, (dt, b["vperp"][0] - v_c, bound)
        assert abs(b["speed"][0] - v_c) <= bound


def unfolded(x0, v, t, r=BALL.radius, length=1.0):
    """Position (m) and velocity (m/s) along one axis at t of a free particle between the walls
    at r and length - r: x0 + v t folded into the span."""
    span = length - 2 * r
    u = (x0 - r + v * t) % (2 * span)
    return (r + u, v) if u <= span else (r + 2 * span - u, -v)


def test_a_particle_crossing_the_box_a_thousand_times_in_a_step_stays_in_it_and_bounces_every_time():
    """--dt 1 s with a particle at (1000, 730) m/s in a 1 m box: about 1000 and 750 crossings in
    the step, more than the contact passes (MAX_PASSES = 100) can take one by one.

    Before, the safety net after the pass limit bounced it once more and left it where it was:
    at dt = 1 s, 1D, 1000 m/s from x = 0.5, it ended at x = -900.52 m, outside the box, with
    101 bounces for 1020. Now the safety net bounces it, earliest contact first, until it is
    inside: every bounce, and the end state of the exact unfolded motion. Round-off: each
    bounce rounds a coordinate of size |v| dt, so k bounces are off by about k eps |v| dt in
    position (2e-10 m here) and that over |v| in time."""
    v, x0, dt = np.array([1000.0, 730.0]), np.array([0.5, 0.3]), 1.0
    sc = Scene(dim=2, length=1.0, duration=dt, components=((BALL, 1),), seed=1, engine="step", dt=dt)
    rec = MemoryRecorder()
    rs = stepper.run(sc, State(x0[None, :], v[None, :], sc.kinds()), rec)
    b = rec.bounces()
    span = 1.0 - 2 * BALL.radius
    tol = 1e4 * np.finfo(float).eps * v.max() * dt
    assert rs.extras["pass_limit_hits"] == 1
    for d in range(2):
        first = (1.0 - BALL.radius - x0[d]) / v[d]
        times = first + span / v[d] * np.arange(int((dt - first) // (span / v[d])) + 1)
        mine = np.abs(b["wall"]) == d + 1
        assert mine.sum() == times.size
        np.testing.assert_allclose(b["t"][mine], times, rtol=0, atol=tol / v[d])
        x, vd = unfolded(x0[d], v[d], dt)
        assert rs.final.positions[0, d] == pytest.approx(x, abs=tol)
        assert rs.final.velocities[0, d] == vd
    assert rs.wall_bounces == b["t"].size == 1020 + 745


def ceiling_and_floor(y0, v, duration, r=BALL.radius, length=1.0):
    """(times s, RE_DIR, |v_perp| m/s) of the bounces of a ball moving straight up and down under
    gravity G between the elastic floor (y = r) and ceiling (y = length - r): parabolas solved in
    closed form, the ceiling when the ball reaches it, else the floor."""
    out, t = [], 0.0
    while True:
        top = length - r - y0
        if v > 0 and v * v >= 2 * G * top:
            s, code = (v - math.sqrt(v * v - 2 * G * top)) / G, 2
        else:
            s, code = (v + math.sqrt(v * v + 2 * G * (y0 - r))) / G, -2
        if t + s > duration:
            return out
        t += s
        out.append((t, code, abs(v - G * s)))
        y0, v = (length - r if code == 2 else r), -(v - G * s)


@pytest.mark.parametrize("dt", [1e-3, 0.05, 0.3, 1.0])
@pytest.mark.parametrize("y0, v", [(0.5, 3.2), (0.5, math.sqrt(2 * G * 0.491))])
def test_a_ball_that_reaches_the_ceiling_within_a_step_bounces_off_it(dt, y0, v):
    """A ball thrown up under gravity: every ceiling and floor bounce, at its closed-form time.

    Before, a ball that went beyond the ceiling and came back below it within one step was not
    seen (only the walls a particle ends beyond were looked at): it flew through the ceiling.
    Thrown at 3.2 m/s (it meets the ceiling at 2.42 m/s): 4 bounces recorded of 5 in 2 s at
    dt = 0.3 s, 2 of 5 at dt = 1 s; grazing it (apex 1 mm above the ceiling, 0.029 s beyond it):
    3 of 4 at dt = 0.05 and 0.3 s, 2 of 4 at dt = 1 s. Kick-drift-kick is exact under
    gravity and the contacts are met on the exact parabola: round-off only."""
    duration = 2.0
    sc = Scene(dim=2, length=1.0, duration=duration, components=((BALL, 1),), seed=1, engine="step", dt=dt,
               gravity=G)
    rec = MemoryRecorder()
    rs = stepper.run(sc, State(np.array([[0.5, y0]]), np.array([[0.0, v]]), sc.kinds()), rec)
    b = rec.bounces()
    expected = ceiling_and_floor(y0, v, duration)
    assert sum(code == 2 for _, code, _ in expected) >= 2
    assert rs.wall_bounces == b["t"].size == len(expected)
    assert list(b["wall"]) == [code for _, code, _ in expected]
    np.testing.assert_allclose(b["t"], [t for t, _, _ in expected], rtol=ROUND_OFF)
    np.testing.assert_allclose(b["vperp"], [w for _, _, w in expected], rtol=ROUND_OFF)
