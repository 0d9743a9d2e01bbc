"""The event engine never hangs silently and keeps its clock resolved.

Each test here is a scene that once hung or went wrong without a word (issue 12): the
runaway guard not running when the record buffers filled first; simulated time standing
still (the reference rate infinite); a settled inelastic bed under gravity crawling for
hours; a clock started late losing the digits of its event times. Every run is bounded
by events, never by wall-clock time: a recorder that has seen far more events than the
guard allows fails the test instead of letting it hang.
"""

from __future__ import annotations

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import driver, guards
from gaz_cli.errors import EngineError
from gaz_cli.model.recording import MemoryRecorder, Recorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

from conftest import radius_for

SMALL_CHUNK = 1 << 16
"""Events between two guard checks in these tests (the engine's own is 4 Mi): the guards
fire within a few hundred thousand events instead of a dozen million."""


class Bounded(MemoryRecorder):
    """Records everything, and fails the test once more than ``limit`` rows have come in:
    a guard that does not fire shows as a failure, not as a hang."""

    def __init__(self, limit: int):
        super().__init__(collisions=True)
        self.rows, self.limit = 0, limit

    def _count(self, n: int) -> None:
        self.rows += n
        if self.rows > self.limit:
            raise AssertionError(f"{self.rows} rows recorded and the engine still runs")

    def add_bounces(self, t, particle, wall, speed, vperp):
        self._count(len(t))

    def add_collisions(self, t, i, j, impulse):
        self._count(len(t))


def unit_scene(dim, n, packing, duration, **kw) -> Scene:
    species = Species("X", 1.0, radius_for(dim, n, packing))
    return Scene(dim=dim, length=1.0, duration=duration, components=((species, n),),
                 temperature=1.0 / K_B, seed=1, **kw)


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(driver, "CHUNK", SMALL_CHUNK)
    monkeypatch.setattr(driver, "FIRST_CHUNK", SMALL_CHUNK // 4)


def test_inelastic_collapse_is_caught_while_every_event_is_recorded(small_chunks, monkeypatch):
    """An inelastic gas without the TC model collapses (ever more collisions in a finite
    time). Recording every collision fills a record buffer (here 4,096 rows) many times
    before a chunk of events (65,536) ends: the guard must still run and end the run with an EngineError."""
    monkeypatch.setattr(driver, "BUFFER_ROWS", SMALL_CHUNK // 16)
    scene = unit_scene(2, 100, 0.4, duration=100.0, restitution=0.3, tc=0.0)
    with pytest.raises(EngineError, match="inelastic collapse"):
        engine.run(scene, initial_state(scene), Bounded(limit=20 * SMALL_CHUNK))


def test_rods_that_fill_the_box_stop_with_a_message(small_chunks):
    """Rods touching end to end from wall to wall: every collision happens at one instant and
    simulated time never moves. The first chunk's rate is infinite; the run must still end
    with an EngineError naming the cause, not loop forever."""
    n, r = 10, 0.05
    scene = Scene(dim=1, length=1.0, duration=1.0, components=((Species("X", 1.0, r), n),),
                  temperature=1.0 / K_B, seed=1)
    x = (r + 2 * r * np.arange(n)).reshape(n, 1)
    v = np.random.default_rng(1).normal(size=(n, 1))
    state = State(x, v, np.zeros(n, dtype=np.int64))
    with pytest.raises(EngineError, match="simulated time stopped"):
        engine.run(scene, state, Bounded(limit=20 * SMALL_CHUNK))


def test_a_disk_at_rest_on_the_floor_stops_with_a_message(small_chunks):
    """One disk lying on the floor under gravity, at rest: each floor 'bounce' at zero speed
    comes at the same instant. The run ends with an EngineError, not a hang."""
    r = 0.05
    scene = Scene(dim=2, length=1.0, duration=1.0, components=((Species("X", 1.0, r), 1),),
                  temperature=1.0 / K_B, seed=1, gravity=10.0)
    state = State(np.array([[0.5, r]]), np.zeros((1, 2)), np.zeros(1, dtype=np.int64))
    with pytest.raises(EngineError, match="simulated time stopped"):
        engine.run(scene, state, Bounded(limit=20 * SMALL_CHUNK))


def test_a_settled_inelastic_bed_ends_with_the_time_reached(small_chunks, monkeypatch):
    """Disks with restitution 0.5 under gravity settle into a bed where, with the TC model,
    each collides every contact time: simulated time crawls. The run ends with an EngineError
    naming the time reached and how many events the rest would take (the engine's limit,
    2e9 events, lowered here to keep the test short)."""
    monkeypatch.setattr(guards, "MAX_PROJECTED_EVENTS", 2e7)
    scene = unit_scene(2, 200, 0.2, duration=100.0, restitution=0.5, gravity=10.0, tc=1e-5)
    with pytest.raises(EngineError, match=r"slowed down at t = .* of 100 s"):
        engine.run(scene, initial_state(scene), Bounded(limit=40_000_000))


def _overlap_free_run(scene, state, start_time):
    rec = MemoryRecorder(collisions=True)
    stats = engine.run(scene, state, rec, start_time=start_time)
    return stats, rec


def test_a_clock_started_late_keeps_its_events_resolved():
    """A run continued at 10^10 mean free times (the clock starts there) has the same events
    as one started at 0: the kernels count time from the run's start, so positions and
    velocities come out bit for bit the same, no collision is found overlapping, and the
    recorded times are the same to the resolution of the late clock."""
    scene = unit_scene(3, 200, 0.3, duration=2.0, boundary="walls")
    state = initial_state(scene)
    early, rec0 = _overlap_free_run(scene, state, 0.0)
    start = 1e10 * 0.05  # the mean free time is about 0.05 here
    late, rec1 = _overlap_free_run(scene, state, start)
    assert early.collisions > 10_000
    assert late.extras["overlapping_collisions"] == 0
    assert np.array_equal(early.final.positions, late.final.positions)
    assert np.array_equal(early.final.velocities, late.final.velocities)
    t0, t1 = rec0.collisions()["t"], rec1.collisions()["t"]
    assert np.all(np.abs((t1 - start) - t0) <= 2 * np.spacing(start))
    assert np.all(np.diff(t1) >= 0)


def test_moving_the_clock_origin_keeps_the_physics(monkeypatch):
    """With the clock's origin moved to 'now' every 20 events a particle (the engine's own
    is 2^20), an elastic fluid still conserves energy exactly, stays inside and apart, and
    records its events in time order on one clock."""
    monkeypatch.setattr(driver, "REBASE_EVENTS_PER_PARTICLE", 20)
    scene = unit_scene(3, 200, 0.3, duration=2.0, boundary="walls")
    state = initial_state(scene)
    masses = scene.masses()
    rec = MemoryRecorder(collisions=True)
    stats = engine.run(scene, state, rec)
    assert stats.extras["rebases"] >= 3
    assert stats.extras["overlapping_collisions"] == 0
    e0 = state.kinetic_energy(masses)
    assert abs(stats.final.kinetic_energy(masses) - e0) <= 1e-12 * e0
    x, r = stats.final.positions, scene.radii()[:, None]
    assert np.all(x >= r * (1 - 1e-12)) and np.all(x <= 1.0 - r * (1 - 1e-12))
    d = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(-1)) + np.eye(len(x))
    assert d.min() >= 2 * r.max() * (1 - 1e-10)
    for t in (rec.collisions()["t"], rec.bounces()["t"]):
        assert np.all(np.diff(t) >= 0) and t[0] >= 0 and t[-1] <= scene.duration


def _exact_hit(dx, dv, sig) -> bool:
    """Whether |dx + dv t| = sig has a root t > 0, decided in exact rational arithmetic on the
    very doubles the kernel receives."""
    from fractions import Fraction as F

    dx, dv, sig = [F(float(a)) for a in dx], [F(float(a)) for a in dv], F(float(sig))
    b = sum(p * q for p, q in zip(dx, dv))
    a = sum(q * q for q in dv)
    c = sum(p * p for p in dx) - sig * sig
    return b < 0 and b * b - a * c > 0


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("distance", [2.0, 50.0, 1000.0])
def test_grazing_pairs_are_decided_as_exact_arithmetic_decides(dim, distance):
    """Pairs launched `distance` diameters apart with an impact parameter within a few 1e-12
    of sigma: the kernel's pair time says 'collide' exactly when rational arithmetic on the
    same doubles does. (With the discriminant written b^2 - a c, 1000 sigma apart agreed in
    15 cases of 40.)"""
    from gaz_cli.engines.event import interactions as K

    rng = np.random.default_rng(dim * 1000 + int(distance))
    sig = 1.0
    agree = 0
    cases = 200
    for _ in range(cases):
        u = rng.normal(size=3)
        u[dim:] = 0.0
        u /= np.linalg.norm(u)
        w = rng.normal(size=3)
        w[dim:] = 0.0
        w -= (w @ u) * u
        w /= np.linalg.norm(w)
        impact = 1.0 - 1e-12 + rng.uniform(-3e-12, 3e-12)
        dx = -distance * sig * u + impact * sig * w
        dv = rng.uniform(0.5, 2.0) * u
        t = K._pair_dt(dx[0], dx[1], dx[2], dv[0], dv[1], dv[2], sig, dim)
        agree += (t < np.inf) == _exact_hit(dx[:dim], dv[:dim], sig)
    assert agree == cases
