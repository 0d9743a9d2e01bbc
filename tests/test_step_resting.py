"""The time-stepped engine's resting contacts: a ball a floor holds at rest meets a collision
where and when it rests, and leaves the floor on the free parabola, whatever dt."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gaz_cli.engines import step as stepper
from gaz_cli.model.recording import MemoryRecorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.model.species import Species

BALL = Species("ball", 1.0, 0.01)
BEAD = Species("bead", 1.0, 0.005)
G = 9.81

ROUND_OFF = 1e-9
"""Relative tolerance against closed forms. Both cases below are exact in the kernel (a free
ball's end state is on its parabola in kick-drift-kick, a held ball rests, the contact is a
root of the true relative path): what is left is round-off, a few eps per operation of a
few hundred steps and of the Newton iterations, far below 1e-9; an error of the scheme's
first-order kind (g dt x the time left in a step) is 1e-4 to 1e-1 here."""


def run(scene, state):
    rec = MemoryRecorder(collisions=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the overlap warning of long steps: not the point here
        stats = stepper.run(scene, state, rec)
    return rec, stats


@pytest.mark.parametrize("dt", [1e-3, 4e-3, 0.01])
def test_a_ball_kicked_off_the_floor_flies_on_the_free_parabola(dt):
    """A bead (R 5 mm, 1 kg) sliding at 1 m/s on a floor of restitution 0 hits a ball (R 1 cm,
    1 kg) at rest on it, below its centre: the line of centres n = (2 sqrt(R r), R - r) / (R + r)
    lifts the ball, which leaves at u n_x n (pair restitution 1) and flies on the parabola from
    the contact; 0.0283 s later (it lands 0.064 s after) its state is compared with that parabola.

    Before, the ball's row in the kernel kept the floor holding it up until the end of the
    collision's step: it ended that step g x (time left) too fast upwards, and stayed so (an
    error first order in dt: at the end, v_y 0.0396 m/s for 0.0366 at dt 1e-3 and 4e-3 (0.3 ms
    left in the step), 0.1181 at dt 0.01 (8.3 ms left); y 0.0150 m for 0.0150 - 8e-5 and
    0.0169)."""
    big, small = BALL.radius, BEAD.radius
    u = 1.0
    gap = 0.0317  # m between the bead and its contact position: contact at t_c = gap / u
    t_c = gap / u
    x_ball = 0.5
    reach = 2.0 * math.sqrt(big * small)  # horizontal distance of the centres at contact
    sc = Scene(dim=2, length=1.0, duration=0.06, components=((BALL, 1), (BEAD, 1)), seed=1, engine="step",
               dt=dt, gravity=G, wall_restitution=0.0, restitution=1.0)
    st = State(np.array([[x_ball, big], [x_ball - reach - gap, small]]), np.array([[0.0, 0.0], [u, 0.0]]),
               sc.kinds())
    rec, stats = run(sc, st)
    c = rec.collisions()
    n = np.array([reach, big - small]) / (big + small)
    v_out = u * n[0] * n
    assert c["t"][0] == pytest.approx(t_c, rel=ROUND_OFF)
    assert c["impulse"][0] == pytest.approx(u * n[0], rel=ROUND_OFF)
    s = sc.duration - t_c
    x = np.array([x_ball + v_out[0] * s, big + v_out[1] * s - 0.5 * G * s * s])
    v = np.array([v_out[0], v_out[1] - G * s])
    ball = int(np.flatnonzero(sc.kinds() == 0)[0])
    np.testing.assert_allclose(stats.final.positions[ball], x, rtol=ROUND_OFF, atol=ROUND_OFF * 0.5)
    np.testing.assert_allclose(stats.final.velocities[ball], v, rtol=ROUND_OFF, atol=ROUND_OFF * 1.0)


@pytest.mark.parametrize("dt", [1e-3, 0.01, 0.05])
def test_a_ball_dropped_on_a_resting_ball_hits_it_at_the_free_fall_time_and_speed(dt):
    """A ball (R 1 cm, 1 kg) dropped from 0.1 m above a ball resting on a floor of restitution 0
    (pair restitution 1, gravity G, 2D, 1 m box): the contact comes at sqrt(2 h / g) with the
    impulse m sqrt(2 g h) (the resting ball is at rest there, the dropped one in free fall).

    Before, the resting ball's drift line in the kernel went up at the support's pace (g dt/2)
    instead of resting: the contact was found late (0.142958 s for 0.142784 at dt 0.01 and
    0.05) and the impulse strong by g x (the time left in the step) (1.4028 kg m/s at dt 1e-3,
    1.4715 at dt 0.01 and 0.05, for 1.4007)."""
    r, h = BALL.radius, 0.1
    sc = Scene(dim=2, length=1.0, duration=0.2, components=((BALL, 2),), seed=1, engine="step", dt=dt,
               gravity=G, wall_restitution=0.0, restitution=1.0)
    st = State(np.array([[0.5, r], [0.5, 3 * r + h]]), np.zeros((2, 2)), sc.kinds())
    rec, _ = run(sc, st)
    c = rec.collisions()
    assert c["t"][0] == pytest.approx(math.sqrt(2 * h / G), rel=ROUND_OFF)
    assert c["impulse"][0] == pytest.approx(math.sqrt(2 * G * h), rel=ROUND_OFF)


@pytest.mark.parametrize("ew", [0.0, 0.7])
@pytest.mark.parametrize("e", [1.0, 0.7, 0.5, 0.0])
@pytest.mark.parametrize("dt", [1e-3, 0.01, 0.05])
def test_a_stack_of_balls_on_the_floor_stays_standing(e, ew, dt):
    """Three balls stacked on a floor (restitution ew) stay at R, 3 R, 5 R at rest for 1 s, pair
    restitution e, and the floor carries their weight: one row a step, the rows summing to
    3 m g T. The ball on the floor is held by it, the one on it by that one, and so on up
    (resting._rest_on): a contact at rest gives back no speed, whatever e, and the weight of
    the balls above reaches the floor through the ones below within the step.

    Met on the true path with the held ball released, the upper ones' contacts became a series
    of vanishing impacts the passes could not end, and the stack sank through itself (y 0.01,
    0.0251, 0.0451 m after 1 s at dt 1e-3; all three at 0.01 m at dt 0.01 and 0.05). Kept on
    the drift lines with restitution e, each step was a series of collisions e^k between the
    balls and the floor, up to the pass limit: on a floor of restitution 0.7 the stack sank by
    0.012 R at dt 0.05 (e 0.7; 5e-6 R at dt 1e-3) and fell at restitution 0.9; e = 0 sank or
    fell on any floor (0.049999999 m for 0.05 at dt 1e-3, all at R at dt 0.05), two held balls
    meeting again at round-off speed (4e-19 m/s) pass after pass. Exact in the kernel:
    round-off only (a few eps a step over 1000 steps: 1e-9 R)."""
    r = BALL.radius
    sc = Scene(dim=2, length=1.0, duration=1.0, components=((BALL, 3),), seed=1, engine="step", dt=dt,
               gravity=G, wall_restitution=ew, restitution=e)
    st = State(np.array([[0.5, r], [0.5, 3 * r], [0.5, 5 * r]]), np.zeros((3, 2)), sc.kinds())
    rec, stats = run(sc, st)
    np.testing.assert_allclose(stats.final.positions, st.positions, rtol=ROUND_OFF, atol=ROUND_OFF * r)
    np.testing.assert_allclose(stats.final.velocities, 0.0, atol=ROUND_OFF * G * dt)
    b = rec.bounces()
    assert len(b["t"]) == stats.extras["steps"]
    assert (1 + ew) * BALL.mass * float(np.sum(b["vperp"])) == pytest.approx(3 * BALL.mass * G * sc.duration,
                                                                         rel=ROUND_OFF)


@pytest.mark.parametrize("dt", [1e-3, 0.01, 0.05])
def test_a_ball_sliding_on_a_tilted_plane_meets_it_once_a_step(dt):
    """A ball (1 kg, R 1 cm) put on a plane of slope 0.2 (the marbles preset's ramp; restitution
    0.7), sliding down it at 1 m/s, 2D, 1 m box, gravity G, 0.3 s: the plane holds it, one
    contact a step, found in the step's first pass (a second finds nothing), and it slides on
    the closed form s = u t + a t^2 / 2, a = G sin(theta), at rest across the plane.

    Before, the move onto the tilted plane left the centre a few ulps behind it (5e-18 m), a
    contact again in every pass: 41 passes and 9.4 contacts a step at dt 1e-3 (2829 in 300
    steps), 41 and 4.4 at dt 0.01. Exact in the kernel but for that round-off."""
    r, slope, u = BALL.radius, 0.2, 1.0
    normal = np.array([slope, 1.0]) / math.hypot(slope, 1.0)
    tangent = np.array([normal[1], -normal[0]])  # down the slope
    point = np.array([0.0, 0.5])
    sc = Scene(dim=2, length=1.0, duration=0.3, components=((BALL, 1),), seed=1, engine="step", dt=dt,
               gravity=G, wall_restitution=0.7, restitution=1.0, planes=((tuple(point), tuple(normal), 0.7),))
    x0 = point + r * normal + 0.3 * tangent
    _, stats = run(sc, State(x0[None], (u * tangent)[None], sc.kinds()))
    steps = stats.extras["steps"]
    assert stats.extras["plane_bounces"] == steps
    assert stats.extras["passes"] == 2 * steps
    a, t = G * normal[0], sc.duration  # G sin(theta): the slope's normal leans by theta
    np.testing.assert_allclose(stats.final.positions[0], x0 + (u * t + 0.5 * a * t * t) * tangent,
                               rtol=ROUND_OFF, atol=ROUND_OFF * r)
    np.testing.assert_allclose(stats.final.velocities[0], (u + a * t) * tangent, rtol=ROUND_OFF, atol=ROUND_OFF)


def two_balls_sliding_on_a_wall(dt, slope):
    """A ball (1 kg, R 1 cm) at rest on a wall of restitution 0.7 and a second one sliding on it
    at 1 m/s into the first, pair restitution 1, gravity G, 2D, 1 m box, 0.3 s: the floor
    (slope None) or an extra plane tilted by ``slope`` (its rise over run; the balls slide down
    it). Returns (scene, state, recorder, stats)."""
    r = BALL.radius
    u = 1.0
    gap = 0.1537  # m between the two balls' surfaces: the collision in the middle of a step
    if slope is None:
        planes, point, tangent, normal = (), np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([0.0, 1.0])
    else:
        normal = np.array([slope, 1.0]) / math.hypot(slope, 1.0)  # falls along +x
        tangent = np.array([normal[1], -normal[0]])
        point = np.array([0.0, 0.5])
        planes = ((tuple(point), tuple(normal), 0.7),)
    sc = Scene(dim=2, length=1.0, duration=0.3, components=((BALL, 2),), seed=1, engine="step", dt=dt,
               gravity=G, wall_restitution=0.7, restitution=1.0, planes=planes)
    base = point + r * normal if slope is not None else np.array([0.0, r])
    x = base + np.outer([0.3 + 2 * r + gap, 0.3], tangent)
    st = State(x, np.outer([0.0, u], tangent), sc.kinds())
    rec = MemoryRecorder(collisions=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stats = stepper.run(sc, st, rec)
    return sc, st, rec, stats


@pytest.mark.parametrize("slope", [None, 0.2])
@pytest.mark.parametrize("dt", [1e-3, 4e-3, 0.01])  # u dt < 2 R: seed 002's overlap rule sees the collision
def test_a_ball_at_rest_on_a_wall_costs_one_contact_a_step_when_hit_along_it(dt, slope):
    """Two balls on a wall (the box's floor, or a ramp of slope 0.2 as in the marbles preset)
    collide along it: each keeps resting on the wall, one contact a step each (the floor's rows,
    the plane's count), and they exchange their velocities along it.

    Before, the collision released both balls from the wall (an impact on a held ball), though
    it pushed neither off nor into it: each fell behind the wall by g tau^2 / 2 in the time left
    and met it again, one more contact a ball for every collision (2 steps + 2 here; in the
    marbles preset's pile on its ramp, 6.0 plane contacts a ball and step at t = 2.6 s, 2.9
    before db25495's holds, 3.0 now). On the ramp the two balls' line of centres is parallel
    to it only to round-off (codes.LIFT_ROUND_OFF): taken for a lift, it released one ball
    (2 steps + 1). Exact in the kernel: the exchange to round-off, the counts exactly."""
    sc, st, rec, stats = two_balls_sliding_on_a_wall(dt, slope)
    steps = stats.extras["steps"]
    assert stats.collisions == 1
    contacts = stats.wall_bounces if slope is None else stats.extras["plane_bounces"]
    assert contacts == 2 * steps
    accel = 0.0 if slope is None else G * slope / math.hypot(slope, 1.0)  # along the ramp, m/s^2
    t = sc.duration
    v_end = np.array([1.0 + accel * t, accel * t])  # the exchange: the first ball leaves at 1 m/s
    v_along = stats.final.velocities @ np.array(st.velocities[1] / np.linalg.norm(st.velocities[1]))
    np.testing.assert_allclose(v_along, v_end, rtol=ROUND_OFF, atol=ROUND_OFF)
    if slope is None:
        b = rec.bounces()
        weight = 1.7 * float(np.sum(sc.masses()[b["particle"]] * b["vperp"]))  # (1 + e_w) m |v_perp|
        assert weight == pytest.approx(2 * BALL.mass * G * t, rel=ROUND_OFF)
