"""The fast event-driven engine (gaz_cli.engines.event): exactness, invariants, stability.

Cross-check against the exam's algorithm (gaz_cli.engines.reference) event by event,
then conservation laws, geometry (nobody outside, nobody overlapping) and the
numerical-stability rules of physics.md §9 on stressed scenes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gaz_cli import theory
from gaz_cli.engines import event as engine
from gaz_cli.engines import reference
from gaz_cli.constants import K_B
from gaz_cli.model.recording import MemoryRecorder, Recorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species


def unit_scene(dim, n, radius, duration=1.0, seed=1, **kw):
    """m = k_B T = 1 (thermal speed 1), box side 1."""
    return Scene(dim=dim, length=1.0, duration=duration, components=((Species("X", 1.0, radius), n),),
                 temperature=1.0 / K_B, seed=seed, **kw)


def event_sequence(rec: MemoryRecorder):
    """All events in time order as (t, kind, a, b): kind 0 wall (a particle, b wall code),
    kind 1 collision (a < b particles)."""
    b, c = rec.bounces(), rec.collisions()
    rows = [(t, 0, int(p), int(w)) for t, p, w in zip(b["t"], b["particle"], b["wall"])]
    rows += [(t, 1, int(min(i, j)), int(max(i, j))) for t, i, j in zip(c["t"], c["i"], c["j"])]
    rows.sort(key=lambda r: r[0])
    return rows


def min_gap(scene: Scene, x: np.ndarray) -> float:
    """Smallest (distance - (R_i + R_j)) / sigma_max over all pairs (minimum image if periodic)."""
    r = scene.radii()
    d = x[:, None, :] - x[None, :, :]
    if scene.boundary == "periodic":
        d -= scene.length * np.rint(d / scene.length)
    dist = np.sqrt((d ** 2).sum(-1))
    gap = dist - (r[:, None] + r[None, :])
    np.fill_diagonal(gap, np.inf)
    return float(gap.min() / (2 * r.max()))


def assert_inside(scene: Scene, x: np.ndarray) -> None:
    r = scene.radii()[:, None]
    if scene.boundary == "walls":
        assert (x >= r * (1 - 1e-12)).all() and (x <= scene.length - r * (1 - 1e-12)).all()
    else:
        assert (x >= 0).all() and (x < scene.length).all()


ROUNDING = float(np.finfo(float).eps)
"""One rounding of a double, relative (2^-52)."""
ROUNDING_SAFETY = 64.0
"""Roundings per event in the time-error model of :func:`time_tolerances` (each event time
takes a handful of operations in either code; measured ratios error/tolerance stay below 1e-2)."""
HORIZON = 1e-6
"""The cross-check stops where the model allows a relative time error of 1e-6: beyond, two
events a millionth apart may legitimately come out in either order."""


def time_tolerances(scene: Scene, events) -> np.ndarray:
    """Relative error allowed on each event's time: ROUNDING_SAFETY * eps * (k + 1) * A**depth.

    The error model. Both codes round each event time at the level of eps; the exam's code
    also shifts every relative time after each event (Q33), so errors add up with the event
    index k. A collision turns a position error d into an angle error d/sigma, which a free
    flight of one mean free path l turns into a position error d*l/sigma: errors are amplified
    by A = l/sigma per collision along the chain of collisions that led to the event (its
    *depth*: one more than the larger depth of the two colliders; a wall bounce keeps the
    particle's depth). In 1D equal rods exchange their velocities and nothing is amplified
    (A = 1). This is chaos seen from one machine: the depths and amplifications are those of
    the trajectory, the same everywhere; only the first roundings differ between CPUs and
    library versions, so the margin measured here holds on any machine.
    """
    if scene.dim == 1:
        amplification = 1.0
    else:
        sigma = 2.0 * float(scene.radii().max())
        density = scene.n / scene.volume
        amplification = max(2.0, theory.mean_free_path(scene.dim, density, sigma) / sigma)
    depth = np.zeros(scene.n, dtype=np.int64)
    out = np.empty(len(events))
    for k, (_, kind, a, b) in enumerate(events):
        if kind == 1:
            depth[a] = depth[b] = max(depth[a], depth[b]) + 1
        out[k] = ROUNDING_SAFETY * ROUNDING * (k + 1) * amplification ** float(depth[a])
    return out


@pytest.mark.parametrize("dim, n, radius", [(1, 20, 0.01), (2, 30, 0.02), (3, 30, 0.04)])
@pytest.mark.parametrize("seed", [3, 4])
def test_same_events_as_the_exam(dim, n, radius, seed):
    """The fast engine and the exam's algorithm, from one initial state, give the same events
    (same particles, same walls, same order) at the same times, within the error model of
    :func:`time_tolerances`, up to the horizon where that model allows 1e-6 (beyond, both
    are valid trajectories of the same gas: chaos has taken the two codes apart)."""
    assert_same_events_as_the_exam(unit_scene(dim, n, radius, duration=6.0, seed=seed))


def assert_same_events_as_the_exam(scene: Scene):
    """Run ``scene`` with the exam's algorithm and the fast engine from one initial state;
    assert the same events at the same times up to the model's horizon; the engine's stats."""
    state = initial_state(scene)
    ref, fast = MemoryRecorder(collisions=True), MemoryRecorder(collisions=True)
    reference.run(scene, state, ref)
    stats = engine.run(scene, state, fast)
    a, b = event_sequence(ref), event_sequence(fast)
    tol = time_tolerances(scene, b)
    horizon = int(np.searchsorted(np.maximum.accumulate(tol), HORIZON))
    a, b, tol = a[:horizon], b[:horizon], tol[:horizon]
    assert len(a) == horizon and horizon >= 50 and sum(r[1] for r in b) >= 8, \
        "scene too quiet for a cross-check"
    assert [r[1:] for r in a] == [r[1:] for r in b]
    ta, tb = np.array([r[0] for r in a]), np.array([r[0] for r in b])
    rel = np.abs(ta - tb) / ta
    assert np.all(rel <= tol), f"event {int(np.argmax(rel / tol))}: {rel.max():.2e} > model"
    return stats


@pytest.mark.parametrize("dim, boundary, packing", [
    (1, "walls", 0.5), (2, "walls", 0.3), (3, "walls", 0.3),
    (2, "periodic", 0.5), (3, "periodic", 0.4),
])
def test_elastic_runs_conserve_energy_stay_inside_and_apart(dim, boundary, packing):
    n = 400
    unit = {1: 2.0, 2: np.pi, 3: 4 * np.pi / 3}[dim]
    radius = (packing / (n * unit)) ** (1 / dim)
    scene = unit_scene(dim, n, radius, duration=2.0, boundary=boundary, seed=5)
    state = initial_state(scene)
    masses = scene.masses()

    class Snapshots(Recorder):
        snapshot_every = 0.25

        def __init__(self):
            self.times = []

        def add_snapshot(self, t, x, v):
            self.times.append(t)
            assert_inside(scene, x)
            assert min_gap(scene, x) > -1e-9
            assert abs(0.5 * np.sum(masses * (v ** 2).sum(1)) - e0) <= 1e-12 * e0

    e0 = state.kinetic_energy(masses)
    rec = Snapshots()
    stats = engine.run(scene, state, rec)
    assert rec.times == pytest.approx(np.arange(9) * 0.25, abs=1e-15)
    assert stats.collisions > 10 * n  # a fluid, not a dilute gas
    assert abs(stats.final.kinetic_energy(masses) - e0) <= 1e-12 * e0
    assert_inside(scene, stats.final.positions)
    assert min_gap(scene, stats.final.positions) > -1e-9
    if boundary == "periodic":
        p0 = (masses[:, None] * state.velocities).sum(0)
        p1 = (masses[:, None] * stats.final.velocities).sum(0)
        scale = (masses[:, None] * np.abs(state.velocities)).sum()
        assert np.abs(p1 - p0).max() < 1e-12 * scale
    # the caller's state is untouched
    assert np.array_equal(state.positions, initial_state(scene).positions)


def test_mixture_of_unequal_masses_conserves_energy_and_records_in_time_order():
    big, small = Species("big", 10.0, 0.03), Species("small", 1.0, 0.01)
    scene = Scene(dim=2, length=1.0, duration=3.0, components=((big, 100), (small, 300)),
                  temperature=1.0 / K_B, seed=2)
    state = initial_state(scene)
    rec = MemoryRecorder(collisions=True)
    stats = engine.run(scene, state, rec)
    m = scene.masses()
    assert abs(stats.final.kinetic_energy(m) / state.kinetic_energy(m) - 1) < 1e-12
    b = rec.bounces()
    assert len(b["t"]) == stats.wall_bounces and np.all(np.diff(b["t"]) >= 0)
    c = rec.collisions()
    assert len(c["t"]) == stats.collisions and np.all(np.diff(c["t"]) >= 0)
    assert set(np.unique(np.abs(b["wall"]))) == {1, 2}
    # the bounce's |v_perp| is at most its speed, and the speed is a real particle's
    assert np.all(b["vperp"] <= b["speed"] * (1 + 1e-12))


def test_momentum_through_walls_matches_the_records():
    """Total momentum changes only by the wall impulses the records report."""
    scene = unit_scene(3, 200, 0.03, duration=1.0, seed=9)
    state = initial_state(scene)
    rec = MemoryRecorder()
    stats = engine.run(scene, state, rec)
    b = rec.bounces()
    m = scene.masses()
    dp = np.zeros(3)
    axis = np.abs(b["wall"]) - 1
    # a wall at L (+) pushes towards -axis, a wall at 0 (-) towards +axis
    np.add.at(dp, axis, -np.sign(b["wall"]) * 2 * m[b["particle"]] * b["vperp"])
    p0 = (m[:, None] * state.velocities).sum(0)
    p1 = (m[:, None] * stats.final.velocities).sum(0)
    assert np.allclose(p1 - p0, dp, rtol=1e-9, atol=1e-9 * np.abs(dp).max())


def test_record_none_gives_the_same_final_state():
    scene = unit_scene(2, 300, 0.015, duration=1.0, seed=4)
    state = initial_state(scene)
    a = engine.run(scene, state, MemoryRecorder(collisions=True))
    b = engine.run(scene, state, Recorder())
    assert np.array_equal(a.final.positions, b.final.positions)
    assert (a.events, a.collisions, a.wall_bounces) == (b.events, b.collisions, b.wall_bounces)


def test_gravity_conserves_mechanical_energy_and_keeps_everyone_in():
    g = 5.0
    scene = unit_scene(2, 300, 0.01, duration=3.0, seed=6, gravity=g)
    state = initial_state(scene)
    m = scene.masses()

    def energy(x, v):
        return float(np.sum(0.5 * m * (v ** 2).sum(1) + m * g * x[:, -1]))

    stats = engine.run(scene, state, Recorder())
    e0, e1 = energy(state.positions, state.velocities), energy(stats.final.positions, stats.final.velocities)
    assert abs(e1 - e0) < 1e-10 * e0
    assert_inside(scene, stats.final.positions)
    assert min_gap(scene, stats.final.positions) > -1e-9
    # the gas has settled towards the floor: the centre of mass is below mid-height
    assert stats.final.positions[:, -1].mean() < 0.5


def test_inelastic_gas_cools_without_stalling():
    scene = unit_scene(2, 400, 0.02, duration=2.0, seed=8, restitution=0.8, tc=1e-4)
    state = initial_state(scene)
    m = scene.masses()
    stats = engine.run(scene, state, Recorder())
    ratio = stats.final.kinetic_energy(m) / state.kinetic_energy(m)
    assert 0.0 < ratio < 0.5
    assert_inside(scene, stats.final.positions)
    assert min_gap(scene, stats.final.positions) > -1e-9


def test_dense_states_are_stable():
    """3D packing 0.45 from a lattice, periodic: a long, collision-dense run stays valid."""
    n = 500
    radius = (0.45 / (n * 4 * np.pi / 3)) ** (1 / 3)
    scene = unit_scene(3, n, radius, duration=1.0, boundary="periodic", placement="lattice", seed=1)
    state = initial_state(scene)
    m = scene.masses()
    stats = engine.run(scene, state, Recorder())
    assert stats.collisions > 100 * n
    assert abs(stats.final.kinetic_energy(m) / state.kinetic_energy(m) - 1) < 1e-11
    assert min_gap(scene, stats.final.positions) > -1e-9


def test_overlapping_start_is_resolved_not_stuck():
    """physics.md §9: an overlapping approaching pair collides at once; a receding one is left alone."""
    scene = unit_scene(1, 2, 0.1, duration=0.05)  # no other event in 0.05 s
    x = np.array([[0.4], [0.5999]])  # overlap by 1e-4
    approaching = State(x, np.array([[1.0], [-1.0]]), np.zeros(2, dtype=np.int64))
    rec = MemoryRecorder(collisions=True)
    stats = engine.run(scene, approaching, rec)
    assert rec.collisions()["t"][0] == 0.0
    assert stats.final.velocities[0, 0] < 0 < stats.final.velocities[1, 0]
    assert stats.extras["overlapping_collisions"] == 1  # the count the no-miss tests rely on
    receding = State(x, np.array([[-1.0], [1.0]]), np.zeros(2, dtype=np.int64))
    rec = MemoryRecorder(collisions=True)
    engine.run(scene, receding, rec)
    c = rec.collisions()
    assert len(c["t"]) == 0  # no spurious collision


def test_tonks_wall_pressure_is_exact_in_1d():
    """physics.md §1: P = sum m v^2 / (L - N sigma) on each wall, for equal masses."""
    n, radius = 50, 0.005  # packing 0.5
    scene = unit_scene(1, n, radius, duration=200.0, seed=2)
    state = initial_state(scene)
    rec = MemoryRecorder()
    engine.run(scene, state, rec)
    b = rec.bounces()
    m = 1.0
    v2 = np.sum(state.velocities ** 2)
    free = 1.0 - n * 2 * radius
    expected = m * v2 / free
    # each ghost hits each wall periodically: the time average is exact up to one hit per
    # ghost, i.e. within sum 2 m |v| / T
    bound = np.sum(2 * m * np.abs(state.velocities)) / scene.duration
    for wall in (-1, 1):
        p = np.sum(2 * m * b["vperp"][b["wall"] == wall]) / scene.duration
        assert abs(p - expected) <= bound
        assert bound < 0.05 * expected


NO_MISS_SCENES = [
    # (dim, boundary, packing, gravity, neighbours)
    (2, "periodic", 0.5, 0.0, "cells"),
    (2, "walls", 0.5, 0.0, "cells"),
    (2, "periodic", 0.6, 0.0, "lists"),
    (3, "periodic", 0.3, 0.0, "cells"),
    (3, "walls", 0.3, 0.0, "cells"),
    (3, "periodic", 0.4, 0.0, "lists"),
    (3, "walls", 0.2, 20.0, "cells"),
    (1, "walls", 0.5, 0.0, "auto"),
]


@pytest.mark.parametrize("dim, boundary, packing, gravity, neighbours", NO_MISS_SCENES)
def test_no_collision_is_ever_missed(dim, boundary, packing, gravity, neighbours):
    """A missed collision shows up later as a pair found overlapping when it finally collides
    (the stability rule makes it collide at once). From a start without overlaps that must
    never happen: the engine counts such collisions, over ~10^5 collisions here. (A merge of
    the new cells' predictions that kept a stale counter for a partner seen again did it
    about once in 10^5 collisions in dense 2D.)"""
    n = 400
    unit = {1: 2.0, 2: np.pi, 3: 4 * np.pi / 3}[dim]
    radius = (packing / (n * unit)) ** (1 / dim)
    total = 0
    for seed in (5, 6, 7, 8, 9):
        scene = unit_scene(dim, n, radius, duration=2.0 if dim > 1 else 0.4, boundary=boundary,
                           seed=seed, gravity=gravity, extras={"neighbours": neighbours})
        stats = engine.run(scene, initial_state(scene), Recorder())
        assert stats.extras["overlapping_collisions"] == 0, (seed, stats.extras)
        total += stats.collisions
    assert total > 1e5


@pytest.mark.parametrize("dim", [2, 3])
def test_a_periodic_box_of_three_cells_an_axis_uses_the_cells_images(dim):
    """Below four cells an axis the nearest image is not always the one in the scanned block:
    the scans carry each cell's image shift instead. Physics checks on such a tiny box."""
    n = 5 if dim == 2 else 20
    unit = {2: np.pi, 3: 4 * np.pi / 3}[dim]
    radius = (0.3 / (n * unit)) ** (1 / dim)
    scene = unit_scene(dim, n, radius, duration=100.0, boundary="periodic", seed=3)
    state = initial_state(scene)
    masses = scene.masses()
    stats = engine.run(scene, state, Recorder())
    assert stats.extras["cells_per_axis"] == 3
    assert stats.collisions > 1000
    assert stats.extras["overlapping_collisions"] == 0
    e0 = state.kinetic_energy(masses)
    assert abs(stats.final.kinetic_energy(masses) - e0) <= 1e-12 * e0
    p0 = (masses[:, None] * state.velocities).sum(0)
    p1 = (masses[:, None] * stats.final.velocities).sum(0)
    assert np.abs(p1 - p0).max() < 1e-12 * (masses[:, None] * np.abs(state.velocities)).sum()
    assert min_gap(scene, stats.final.positions) > -1e-9


def test_no_collision_is_missed_in_the_standard_scene():
    """The standard scene of the benchmarks (3D periodic, N = 4000, packing 0.3, FCC start)
    over about 10^6 collisions. (Trusting a second prediction that a crossing's partial scan
    had filled in missed about 3 collisions in 10^6 here, and biased beta P low by 0.1%.)"""
    n, eta = 4000, 0.3
    length = (n * np.pi / 6 / eta) ** (1 / 3)
    total = 0
    for seed in (1, 2):
        scene = Scene(dim=3, length=length, duration=25.0,
                      components=((Species("X", 1.0, 0.5), n),), temperature=1.0 / K_B,
                      seed=seed, boundary="periodic", placement="lattice", record="none")
        stats = engine.run(scene, initial_state(scene), Recorder())
        assert stats.extras["overlapping_collisions"] == 0, seed
        total += stats.collisions
    assert total > 9e5


def test_neighbour_lists_in_a_tiny_periodic_box_list_each_neighbour_once():
    """Two disks in a periodic box small enough for 2 cells an axis: a list gathers from
    3 cells an axis, so the box gets 3, and each disk lists the other once (with 2 it
    listed it once per image cell). Found by review; the duplicates only cost time."""
    from gaz_cli.engines.event import driver

    scene = unit_scene(2, 2, 0.1056, duration=3.0, boundary="periodic", seed=2,
                       extras={"neighbours": "lists"})
    state = State(np.array([[0.3, 0.3], [0.55, 0.3]]), np.array([[0.3, 0.01], [0.31, -0.01]]),
                  np.zeros(2, dtype=np.int64))
    sim = driver._Simulation(scene, state, Recorder())
    assert sim.use_nl and sim.nc >= 3
    assert list(sim.NN) == [1, 1]
    stats = sim.run()
    assert stats.extras["list_rebuilds"] > 10 and list(sim.NN) == [1, 1]


def test_work_per_event_does_not_grow_with_n(make_scene):
    """O(1) per event: at the same packing fraction, 16 times more particles cost the same pair
    times and calendar steps per event (cells stay about one diameter wide, buckets hold a few
    events). A time per event that grows with N is the memory hierarchy, not the algorithm
    (benchmarks/engine.py, figure f)."""
    work = {}
    for n in (1000, 16000):
        # diameter about 1 whatever n: the same mean free time
        length = (n * math.pi / 6.0 / 0.3) ** (1.0 / 3.0)
        sc = make_scene(dim=3, n=n, packing=0.3, length=length, duration=1.0, seed=4,
                        boundary="periodic", record="none")
        rs = engine.run(sc, initial_state(sc))
        q = rs.extras["queue_events"]
        assert rs.collisions > 4 * n
        work[n] = (rs.extras["pair_tests"] / q, rs.extras["calendar_steps"] / q,
                   q / rs.collisions)
    (p1, s1, e1), (p16, s16, e16) = work[1000], work[16000]
    assert 10.0 < p1 < 40.0 and p16 == pytest.approx(p1, rel=0.25)
    assert s1 < 1.0 and s16 < 1.0
    assert e16 == pytest.approx(e1, rel=0.1)
