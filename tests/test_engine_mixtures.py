"""Cells per size class (gaz_cli.engines.event.neighbours.classes): mixtures of very different sizes.

The plan's grids (sizes, the coarse cells' width), the adjacency rule (a pair in contact is
adjacent), then whole runs: the same events as one grid, no collision missed, energy and
momentum conserved, nobody outside the box.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from gaz_cli.engines import event as engine
from gaz_cli.constants import K_B
from gaz_cli.engines.event import driver, sizing
from gaz_cli.engines.event.interactions import pair_reach
from gaz_cli.engines.event.neighbours import ball, classes
from gaz_cli.model.recording import MemoryRecorder, Recorder
from gaz_cli.model.scene import Scene, State
from gaz_cli.placement.initial import initial_state
from gaz_cli.model.species import Species

from test_event_engine import HORIZON, assert_inside, event_sequence, time_tolerances

SMALL = Species("small", 1.0, 1.0)

# (dim, boundary, small, large, r_large, box, duration): 1:20 in radius, 1 % large by number;
# the large ones as heavy as the small (as fast: they cross many fine cells, the stress case)
MIXTURES = {
    (2, "walls"): (1000, 10, 20.0, 300.0, 40.0),
    (3, "periodic"): (4000, 40, 20.0, 200.0, 40.0),
    # a box of 3.5 large reaches: three coarse cells an axis, whose scans carry image codes
    (2, "periodic, 3 coarse"): (200, 6, 10.0, 70.0, 40.0),
    (3, "periodic, 3 coarse"): (2000, 12, 10.0, 70.0, 40.0),
    # a box of 2.5 large reaches: two coarse cells an axis, each scanned at two images
    (2, "periodic, 2 coarse"): (200, 3, 10.0, 50.0, 40.0),
    (3, "periodic, 2 coarse"): (1000, 6, 10.0, 50.0, 40.0),
}


def mixture(dim, boundary, seed=1, classes_mode="auto", duration=None):
    ns, nl, rl, length, dur = MIXTURES[(dim, boundary)]
    comps = ((Species("large", 1.0, rl), nl), (SMALL, ns))  # large first: placed first
    return Scene(dim=dim, length=length, duration=dur if duration is None else duration,
                 components=comps, temperature=1.0 / K_B, seed=seed, boundary=boundary.split(",")[0],
                 extras={"classes": classes_mode})


def min_gap(scene, x):
    """Smallest (distance - (R_i + R_j)) / (2 r_small) over the pairs within reach (a k-d tree:
    test_event_engine.min_gap's N^2 distances would take seconds here)."""
    from scipy.spatial import cKDTree

    r = scene.radii()
    per = scene.boundary == "periodic"
    tree = cKDTree(x, boxsize=scene.length if per else None)
    ij = tree.query_pairs(2 * r.max(), output_type="ndarray")
    d = x[ij[:, 0]] - x[ij[:, 1]]
    if per:
        d -= scene.length * np.rint(d / scene.length)
    gap = np.sqrt((d ** 2).sum(1)) - r[ij[:, 0]] - r[ij[:, 1]]
    return float(gap.min() / (2 * SMALL.radius)) if gap.size else math.inf


def _plan(radii, dim, length, periodic=False, use_nl=False):
    return classes.plan(np.asarray(radii, dtype=float), dim, length, periodic, True, use_nl,
                        lambda r: pair_reach(r, ()), sizing.cells_per_axis)


def test_plan_keeps_one_grid_unless_the_radii_are_far_apart():
    assert _plan([1.0] * 100, 3, 100.0) is None  # one size
    assert _plan([1.0] * 100 + [5.0] * 5, 3, 100.0) is None  # 1:5, below MIN_RATIO
    assert _plan([1.0] * 100 + [20.0] * 5, 3, 300.0, use_nl=True) is None  # lists
    assert _plan([1.0] * 100 + [20.0] * 5, 1, 3000.0) is None  # 1D: the line
    assert _plan([1.0] * 100 + [20.0] * 5, 3, 300.0) is not None


@pytest.mark.parametrize("dim, periodic", [(2, False), (3, True), (3, False)])
def test_the_coarse_cells_hold_every_pair_of_large_and_small_in_reach(dim, periodic):
    """Coarse cells at least one large-large reach wide (2 rmax), and at least the ball's
    half-width bcl of fine cells (a small and a large particle adjacent are in coarse cells
    next to each other); a periodic box holds whole coarse cells."""
    radii = [1.0] * 2000 + [20.0] * 20 + [15.0] * 5
    length = 400.0
    mx = _plan(radii, dim, length, periodic)
    a = length / mx.nc
    assert mx.f * a >= 2 * 20.0
    assert mx.f >= mx.bcl
    assert mx.rcut == 1.0 and mx.n_small == 2000 and mx.n_large == 25
    assert a >= 2.0  # fine cells at least one small-small reach wide
    if periodic:
        assert mx.nc == mx.f * mx.ncl and mx.ncl >= 4
    else:
        assert mx.ncl == math.ceil(mx.nc / mx.f)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_small_and_a_large_particle_in_contact_are_adjacent(dim, rng):
    """The rule the search is exact by: two centres within reach (r_s + r_L) lie in fine cells
    that are adjacent (sum of max(0, |dc| - 1)^2 <= RINT), wherever they are in their cells,
    up to contact."""
    length = 400.0
    n_small = 2000 if dim == 2 else 100000  # fine cells a third of the reach wide, or less
    mx = _plan([1.0] * n_small + [20.0] * 20, dim, length)
    a = length / mx.nc
    reach = 21.0
    assert a < reach / 3
    xs = rng.uniform(reach, length - reach, size=(2000, dim))
    u = rng.normal(size=(2000, dim))
    u *= (reach * rng.uniform(0.0, 1.0, size=2000) ** (1 / dim)
          / np.linalg.norm(u, axis=1))[:, None]
    u[:200] *= reach / np.linalg.norm(u[:200], axis=1)[:, None]  # exactly in contact
    cs = np.floor(xs / a).astype(np.int64)
    cl = np.floor((xs + u) / a).astype(np.int64)
    for c1, c2 in zip(cs, cl):
        s = sum(ball._far(int(o)) for o in c2 - c1)
        assert s <= mx.rint, (c1, c2, mx)
    # and the ball is no wider than needed: a pair two ball widths apart is not adjacent
    assert ball._far(2 * mx.bcl) > mx.rint


@pytest.mark.parametrize("dim", [2, 3])
def test_the_ball_counts_every_fine_cell_adjacent_to_a_large_particle(dim):
    """ball.ball_cells (counted a column at a time) against every offset within the ball's
    half-width whose sum of _far is at most RINT, counted one by one."""
    import itertools

    for rint in list(range(0, 40)) + [97, 400]:
        b = 1 + math.isqrt(rint)
        far = [ball._far.py_func(o) for o in range(-b, b + 1)]
        count = sum(1 for c in itertools.product(far, repeat=dim) if sum(c) <= rint)
        assert ball.ball_cells(dim, rint) == count, rint


@pytest.mark.parametrize("dim, boundary", list(MIXTURES))
def test_size_classes_give_the_events_of_one_grid(dim, boundary):
    """Same scene, same start, one grid (classes 'off') against size classes: the same events
    (kind, particles) in the same order, times within the round-off model of
    test_event_engine.time_tolerances, up to where that model allows 1e-6. Fine and coarse
    cells snap a crossing particle onto other faces, so the two runs differ by round-off
    that collisions amplify: beyond that horizon they may diverge (chaos), not before."""
    scene = mixture(dim, boundary, seed=3)
    state = initial_state(scene)
    seqs = []
    for mode in ("off", "auto"):
        rec = MemoryRecorder(collisions=True)
        stats = engine.run(dataclasses.replace(scene, extras={"classes": mode}), state, rec)
        assert stats.extras["size_classes"] == (mode == "auto")
        seqs.append(event_sequence(rec))
    one, two = seqs
    # the round-off model's amplification per collision, l / sigma, taken for a gas of as many
    # small particles alone: a longer free path than the mixture's, a smaller sigma than any
    # pair's (a collision with a large particle turns a position error d into an angle
    # d / (r_s + r_L) only): a bound of the mixture's
    alone = dataclasses.replace(scene, components=((SMALL, scene.n),))
    tol = time_tolerances(alone, one)
    k = int(np.searchsorted(tol >= HORIZON, True))
    # enough to say something (measured: 838 events, 119 with a large particle, in 2D; 439 and
    # 306 in 3D; the whole runs, 2714 and 4599 events, came out the same here)
    assert k > 50
    n_large = MIXTURES[(dim, boundary)][1]  # the large ones are numbered first
    assert sum(1 for e in one[:k] if e[1] == 1 and e[2] < n_large) > 20
    for e1, e2, rt in zip(one[:k], two[:k], tol[:k]):
        assert e1[1:] == e2[1:], (e1, e2)
        assert abs(e1[0] - e2[0]) <= rt * max(1.0, abs(e1[0])), (e1, e2, rt)


@pytest.mark.parametrize("dim, boundary", list(MIXTURES))
def test_size_classes_miss_no_collision_and_conserve(dim, boundary):
    """A missed pair shows up as a pair found overlapping when it finally collides (the engine
    counts them): none over three seeds. Elastic: the kinetic energy to 1e-12 relative (round-
    off, ~1e-16 an event over ~10^4-10^5 events), the momentum of a periodic box to 1e-12 of the
    momentum scale; at the end nobody overlaps (1e-9 of a small diameter: round-off) and nobody
    is out."""
    total = 0
    large_small = 0
    for seed in (5, 6, 7):
        scene = mixture(dim, boundary, seed=seed)
        state = initial_state(scene)
        rec = MemoryRecorder(collisions=True)
        stats = engine.run(scene, state, rec)
        assert stats.extras["size_classes"]
        assert stats.extras["overlapping_collisions"] == 0, (seed, stats.extras)
        m = scene.masses()
        e0 = state.kinetic_energy(m)
        assert abs(stats.final.kinetic_energy(m) - e0) <= 1e-12 * e0
        if scene.boundary == "periodic":
            p0 = (m[:, None] * state.velocities).sum(0)
            p1 = (m[:, None] * stats.final.velocities).sum(0)
            assert np.abs(p1 - p0).max() <= 1e-12 * (m[:, None] * np.abs(state.velocities)).sum()
        assert min_gap(scene, stats.final.positions) > -1e-9
        assert_inside(scene, stats.final.positions)
        c = rec.collisions()
        n_large = MIXTURES[(dim, boundary)][1]
        large_small += int(np.sum((np.minimum(c["i"], c["j"]) < n_large)
                                  & (np.maximum(c["i"], c["j"]) >= n_large)))
        total += stats.collisions
    assert total > 5000 and large_small > 1000, (total, large_small)


@pytest.mark.parametrize("dim, boundary", list(MIXTURES))
def test_the_counts_of_large_particles_near_follow_their_crossings(dim, boundary):
    """The fine cells' counts of large particles near (CV), kept up at every crossing of a large
    particle, equal the counts made afresh from the final positions (a count too low hides a
    large particle from the small ones; one too high costs lookups)."""
    scene = mixture(dim, boundary, seed=4, duration=20.0)
    sim = driver._Simulation(scene, initial_state(scene), Recorder())
    stats = sim.run()
    assert stats.extras["size_classes"] and stats.extras["cell_crossings"] > 1000
    kept = sim.CV.copy()
    mx = sim.mix
    ball._cover_fill(sim.P, sim.I, sim.CV, mx.nc, mx.bcl, mx.rint, mx.rcut, dim,
                        scene.boundary == "periodic")
    assert kept.sum() > 0
    np.testing.assert_array_equal(kept, sim.CV)


@pytest.mark.parametrize("dim", [2, 3])
def test_three_coarse_cells_take_the_blocks_image_not_the_nearest(dim):
    """A periodic box three coarse cells wide (30, cells of 10; large spheres of radius 4.5):
    large ones at x = 2 and x = 18, closing in at speed 2, meet at t = 3.5 without leaving
    their coarse cells. From either, the other is 16 away in the scan's block and 14 away in
    the nearest image (the other way, parting): a scan that took the nearest image would
    miss the collision (they would pass through each other). 100 small ones rest far off."""
    big, small = Species("large", 1.0, 4.5), Species("small", 1.0, 0.45)
    scene = Scene(dim=dim, length=30.0, duration=5.0, components=((big, 2), (small, 100)),
                  temperature=1.0 / K_B, seed=1, boundary="periodic")
    x = np.zeros((102, dim))
    x[0, 0], x[1, 0] = 2.0, 18.0
    x[:2, 1:] = 15.0
    g = np.arange(100)
    if dim == 2:  # a band of 20 x 5 at rest, y 22..28
        x[2:, 0], x[2:, 1] = 1.5 * (g % 20), 22.0 + 1.5 * (g // 20)
    else:  # a layer of 10 x 10 at rest, z = 25
        x[2:, 0], x[2:, 1], x[2:, 2] = 3.0 * (g % 10), 3.0 * (g // 10), 25.0
    v = np.zeros((102, dim))
    v[0, 0], v[1, 0] = 1.0, -1.0
    state = State(x, v, np.r_[0, 0, np.ones(100, dtype=int)])
    rec = MemoryRecorder(collisions=True)
    stats = engine.run(scene, state, rec)
    assert stats.extras["size_classes"] and stats.extras["coarse_cells_per_axis"] == 3
    c = rec.collisions()
    assert len(c["t"]) >= 1 and {int(c["i"][0]), int(c["j"][0])} == {0, 1}
    assert c["t"][0] == pytest.approx(3.5, rel=1e-12)
    assert stats.extras["overlapping_collisions"] == 0
    assert min_gap(scene, stats.final.positions) > -1e-9
