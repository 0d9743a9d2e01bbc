"""Wide cells scanned by the float32 pass (gaz_cli.engines.event.neighbours.wide); and when 'auto'
takes them (gaz_cli.engines.event.sizing.use_wide_cells)."""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np
import pytest
from test_engine_dilute import (ENERGY_RTOL, adversarial_rows, assert_exact_runs, energy,
                                readme_scene, scene_b)
from test_event_engine import (HORIZON, assert_same_events_as_the_exam, event_sequence, min_gap,
                               time_tolerances, unit_scene)

from gaz_cli.engines import event as engine
from gaz_cli.engines.event import sizing
from gaz_cli.engines.event.dynamics import _relative_at
from gaz_cli.engines.event.interactions import _pair_time
from gaz_cli.engines.event.boundaries import _crossing
from gaz_cli.engines.event.layout import C0, CELL, I_WIDTH, PR, PT, PV, SLOT, TCOL, TCOL2
from gaz_cli.engines.event.neighbours.cells import _assign_cells
from gaz_cli.engines.event.neighbours.dilute import KEEP, XC_SIZE
from gaz_cli.engines.event.neighbours.wide import _mirror_all, _path_block, _predict_wide
from gaz_cli.model.recording import MemoryRecorder, Recorder
from gaz_cli.placement.initial import initial_state

WIDE = {"neighbours": "wide"}


@pytest.fixture
def four_cells(monkeypatch):
    """Wide cells forced to 4 an axis (small scenes: crossings and partial scans happen)."""
    monkeypatch.setattr(sizing, "wide_cells_per_axis", lambda *a: 4)


@pytest.mark.parametrize("dim, n, radius", [(2, 30, 0.02), (3, 30, 0.04), (3, 60, 0.03)])
@pytest.mark.parametrize("seed", [3, 4])
def test_same_events_as_the_exam(dim, n, radius, seed, four_cells):
    """Wide cells and the exam's algorithm give the same events in the same order at the
    same times, within test_event_engine's error model, up to its horizon."""
    stats = assert_same_events_as_the_exam(unit_scene(dim, n, radius, duration=6.0, seed=seed,
                                                      extras=WIDE))
    assert stats.extras["wide_cells"] and stats.extras["cell_crossings"] > 0


@pytest.mark.parametrize("dim, packing", [(2, 0.2), (3, 0.05), (3, 0.25)])
def test_no_collision_is_missed_energy_is_kept_nobody_leaves(dim, packing, four_cells):
    """Forced on gases from dilute to dense (where the pass keeps many pairs): no pair is
    ever found overlapping when it collides (a missed collision would be, later), the
    energy stays within ENERGY_RTOL, every particle ends inside the box and apart."""
    assert_exact_runs(dim, packing, WIDE,
                      lambda extras: extras["wide_cells"] and extras["cell_crossings"] > 0)


@pytest.mark.parametrize("dim, n, radius", [(2, 200, 0.01), (3, 300, 0.02)])
@pytest.mark.parametrize("seed", [3, 4])
@pytest.mark.parametrize("per_axis", [3, 4])
def test_periodic_same_events_as_cells(dim, n, radius, seed, per_axis, monkeypatch):
    """In a periodic box (no wall: each particle's horizon is its next wrap, where it scans in
    full; a cell across a face scanned through its image), wide cells (3 an axis: each cell
    seen through one image, the fewest allowed; 4) and cells a diameter wide give the same
    events in the same order at the same times, within test_event_engine's error model, up
    to its horizon (the exam's code has no periodic box: cells, checked against it with
    walls, stand in)."""
    monkeypatch.setattr(sizing, "wide_cells_per_axis", lambda *a: per_axis)
    scene = unit_scene(dim, n, radius, duration=6.0, seed=seed, boundary="periodic")
    state = initial_state(scene)
    runs = []
    for search in ("cells", "wide"):
        rec = MemoryRecorder(collisions=True)
        stats = engine.run(dataclasses.replace(scene, extras={"neighbours": search}), state, rec)
        runs.append(event_sequence(rec))
    assert stats.extras["wide_cells"] and stats.extras["cells_per_axis"] == per_axis
    assert stats.extras["cell_crossings"] > 10 * n  # (wraps among them)
    cells, wide = runs
    tol = time_tolerances(scene, wide)
    horizon = int(np.searchsorted(np.maximum.accumulate(tol), HORIZON))
    assert horizon >= 50, "scene too quiet for a cross-check"
    assert [r[1:] for r in cells[:horizon]] == [r[1:] for r in wide[:horizon]]
    tc, tw = (np.array([r[0] for r in run[:horizon]]) for run in (cells, wide))
    assert np.all(np.abs(tc - tw) / tc <= tol[:horizon])


@pytest.mark.parametrize("dim, packing", [(2, 0.2), (3, 0.08)])
def test_periodic_no_collision_is_missed_energy_is_kept_nobody_leaves(dim, packing, four_cells):
    """Forced in a periodic box: no pair found overlapping when it collides (a collision
    missed across a face, or after a wrap, would be, later), energy within ENERGY_RTOL,
    everyone inside the box and apart (minimum image)."""
    assert_exact_runs(dim, packing, WIDE,
                      lambda extras: extras["wide_cells"] and extras["cell_crossings"] > 0,
                      boundary="periodic")


def test_a_full_cell_widens_its_block_and_the_run_stays_exact(monkeypatch, four_cells):
    """Cells made with room for one particle: they fill at once, the table and the blocks
    grow (their slots kept) and the run goes on exact (no overlap, energy kept)."""
    monkeypatch.setattr(sizing, "_cell_capacity", lambda per_cell: 1)
    scene = unit_scene(3, 200, 0.02, duration=3.0, seed=8, extras=WIDE)
    state = initial_state(scene)
    stats = engine.run(scene, state, Recorder())
    assert stats.extras["wide_cells"] and stats.extras["cell_growths"] > 0
    assert stats.extras["overlapping_collisions"] == 0
    e0, e1 = energy(scene, state.velocities), energy(scene, stats.final.velocities)
    assert abs(e1 - e0) <= ENERGY_RTOL * e0
    assert min_gap(scene, stats.final.positions) > -1e-9
    assert stats.collisions > 500


def test_collisions_and_bounces_agree_with_cells():
    """The same gas run with cells and with wide cells (the model's count an axis): the two
    trajectories part by chaos, so their counts are compared as Poisson counts (within 5
    standard deviations, sqrt(2 k) for the difference of two counts near k)."""
    scene = unit_scene(3, 2000, 0.006, duration=1.0, seed=2)
    state = initial_state(scene)
    cells = engine.run(dataclasses.replace(scene, extras={"neighbours": "cells"}), state)
    wide = engine.run(dataclasses.replace(scene, extras=WIDE), state)
    assert not cells.extras["wide_cells"] and wide.extras["wide_cells"]
    assert wide.extras["cells_per_axis"] < cells.extras["cells_per_axis"]
    for k in ("collisions", "wall_bounces"):
        a, b = getattr(cells, k), getattr(wide, k)
        assert a > 1000 and abs(a - b) <= 5 * math.sqrt(a + b), k


@pytest.mark.parametrize("scene, wide", [
    (scene_b(), True),  # 10^4 atoms, packing 0.01: wide cells
    # 2000 atoms: the dilute scan is cheaper than cells, wide cells cheaper still (1.56x
    # the dilute scan's events a second, which 'auto' took when it weighed it against cells)
    (scene_b(n=2000), True),
    # packing 0.04: wide cells (1.24x the events a second of cells at 0.05, N = 2000); 0.15:
    # cells (sizing.WIDE_BELOW; wide cells 0.83-0.91x as fast from 0.12 on)
    (scene_b(n=2000, packing=0.04), True),
    (scene_b(n=2000, packing=0.15), False),
    (readme_scene(), False),  # the dilute scan (no cells at all)
    # periodic: wide cells at packing 0.01 (1.91x) and in argon at 1 atm (packing 0.0005);
    # cells at 0.15
    (scene_b(boundary="periodic"), True),
    (scene_b(boundary="periodic", packing=0.0005), True),
    (scene_b(boundary="periodic", packing=0.15), False),
    (scene_b(gravity=9.81), False),  # no gravity
    (unit_scene(3, 2000, (0.3 / (2000 * 4 / 3 * math.pi)) ** (1 / 3), duration=1e-4), False),
    (scene_b(extras={"neighbours": "cells"}), False),  # forced
    (unit_scene(3, 500, 0.05, duration=1e-3, extras=WIDE), True),  # forced, dense
])
def test_auto_takes_wide_cells_for_dilute_gases(scene, wide):
    stats = engine.run(scene, initial_state(scene), Recorder())
    assert stats.extras["wide_cells"] is wide
    if wide:
        assert not stats.extras["dilute_scan"] and stats.extras["dilute_scanned"] > 0


# --- the scan: it only filters (module docstring of neighbours.wide) ---

@numba.njit  # (not cached: Numba's cache would not see a change of the engine's helpers)
def _kept_and_found(P, F, XC, nc, t_mirror, t, tw, L, D, PER):
    """Particle 0's scan (its row at t) of the 3^D cells around it in wide cells, nc an axis,
    up to the horizon tw, after the rows were mirrored at t_mirror: which particles the pass
    kept, which ones the exact float64 root finds in contact by tw, and its two predictions.
    F: the rows as the scan sees them (with walls P itself; PER, a periodic box: each
    partner in the image its cell is scanned through)."""
    n = P.shape[0]
    I = np.zeros((n, I_WIDTH), np.int32)
    cap = n
    cells = np.zeros((nc ** D, cap + 1), np.int32)
    _assign_cells(P, I, cells, nc, L / nc, D)
    XB = np.zeros((nc ** D, 9, 8 * ((cap + 7) // 8)), np.float32)
    XB[:, 0, :] = 1e10
    _mirror_all(P, I, XB, XC, n, t_mirror, L)
    EV = np.full((n, 4), np.inf)
    GB = np.zeros(3 ** D * cap, np.int32)
    GS = np.zeros(3 ** D * cap, np.int32)
    _predict_wide(P, I, EV, cells, XB, XC, GB, GS, 0, t, tw, n, nc, L, 0.0, -1, 1, -1, 1,
                  -1 if D > 2 else 0, 1 if D > 2 else 0, (1.0, 0.0), D, PER)
    kept = np.zeros(n, np.bool_)
    times = np.full(n, np.inf)
    for m in range(1, n):
        kept[m] = XB[I[m, CELL], KEEP, I[m, SLOT] - 1] <= 0.0
        dx0, dx1, dx2, dv0, dv1, dv2 = _relative_at(F, m, t, F[0, 0], F[0, 1], F[0, 2],
                                                    F[0, PV], F[0, PV + 1], F[0, PV + 2],
                                                    0.0, 3, False)
        times[m] = t + _pair_time(dx0, dx1, dx2, dv0, dv1, dv2, F[0, PR], F[m, PR], (1.0, 0.0), 3)
    return kept, times, EV[0, TCOL], EV[0, TCOL2]


@pytest.mark.parametrize("case, dim, L, radius, speed, t, t_mirror, age", [
    ("unit box", 3, 1.0, 0.01, 1.0, 0.3, 0.0, 0.5),
    ("2D", 2, 1.0, 0.01, 1.0, 0.3, 0.0, 0.5),
    ("box 10^4 diameters wide", 3, 1.0, 5e-5, 1.0, 0.3, 0.0, 1.0),
    ("argon in SI units, late in the run (stamps rebased)", 3, 3.4e-8, 1.7e-10, 400.0, 7.3e-9,
     0.0, 4e-11),
])
@pytest.mark.parametrize("seed", [1, 2])
def test_the_scan_keeps_every_pair_the_exact_root_finds_before_the_next_bounce(
        case, dim, L, radius, speed, t, t_mirror, age, seed):
    """Partners set up to touch particle 0 (at the box centre, 3 cells an axis: all in view)
    before its next wall bounce, grazing, touching now, overlapping, just inside that
    horizon, in boxes 10^4 diameters wide and in SI units: every one the exact float64 root
    finds in contact by the bounce is kept by the float32 pass, and the two predictions are
    the two earliest of them, exactly."""
    rng = np.random.default_rng(seed)
    v0 = speed * rng.normal(size=dim)
    x0 = np.full(dim, 0.5 * L)
    horizon = float(np.min((0.5 * L - radius) / np.abs(v0)))  # (its next wall bounce)
    P = adversarial_rows(rng, 3000, dim, L, radius, speed, t, horizon, age, at=(x0, v0))
    tw = t + horizon
    kept, times, t1, t2 = _kept_and_found(P, P, np.zeros(XC_SIZE), 3, t_mirror, t, tw, L, dim,
                                          False)
    found = times <= tw
    assert found.sum() > 1000, found.sum()  # (most partners do touch by the horizon)
    missed = np.flatnonzero(found & ~kept)
    assert missed.size == 0, (missed[:5], P[missed[:5]])
    first, second = np.sort(times[found])[:2]
    assert (t1, t2) == (first, second)


@pytest.mark.parametrize("dim, L, radius, speed, t, age", [
    (3, 1.0, 0.01, 1.0, 0.3, 0.5),
    (2, 1.0, 0.01, 1.0, 0.3, 0.5),
    (3, 3.4e-8, 1.7e-10, 400.0, 7.3e-9, 4e-11),  # argon in SI units, late in the run
])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_periodic_scan_keeps_every_pair_the_exact_root_finds_through_the_images(
        dim, L, radius, speed, t, age, seed):
    """A periodic box, 3 cells an axis: particle 0 near a corner of the box (cell 0, a
    twentieth of the box from its faces), partners set up as in the test above in the frame
    of the images its scan sees (the box shifted by a third: cells -1, 0, 1 around it), then
    wrapped into the box, so that many of them sit across a face. Every partner that the
    exact float64 root, taken in that frame, puts in contact by particle 0's next wrap is kept
    by the float32 pass, through its cell's image, and the two predictions are the two
    earliest of them, exactly."""
    rng = np.random.default_rng(40 + seed)
    third = L / 3.0
    v0 = speed * rng.normal(size=dim)
    x0 = np.full(dim, 0.05 * L)
    horizon = float(np.min(np.where(v0 > 0.0, L - x0, x0) / np.abs(v0)))  # (its next wrap)
    F = adversarial_rows(rng, 3000, dim, L, radius, speed, t, horizon, age,
                         at=(x0 + third, v0))
    P = F.copy()
    P[:, :dim] -= third
    P[:, :dim] += np.where(P[:, :dim] < 0.0, L, 0.0)  # wrapped: across a face, cell 2
    assert (P[:, :dim] >= 0.0).all() and (P[:, :dim] < L).all()
    assert np.mean(np.any(F[:, :dim] < third, axis=1)) > 0.25  # many through an image
    tw = t + horizon
    kept, times, t1, t2 = _kept_and_found(P, F, np.zeros(XC_SIZE), 3, 0.0, t, tw, L, dim, True)
    found = times <= tw
    assert found.sum() > 1000, found.sum()
    missed = np.flatnonzero(found & ~kept)
    assert missed.size == 0, (missed[:5], P[missed[:5]])
    first, second = np.sort(times[found])[:2]
    assert (t1, t2) == (first, second)


# --- the cells a scan covers: those a partner can be in when it touches (_path_block) ---

@numba.njit  # (not cached: Numba's cache would not see a change of the engine's helpers)
def _covered(P, XC, nc, L, D):
    """Particle 0's exit time from its cell (its next crossing or bounce, as the loop times
    it), and for each row whether its cell is in the block of cells :func:`_path_block`
    gives for particle 0's path until then (those its scan covers)."""
    n = P.shape[0]
    I = np.zeros((n, I_WIDTH), np.int32)
    cells = np.zeros((nc ** D, n + 1), np.int32)
    _assign_cells(P, I, cells, nc, L / nc, D)
    XB = np.zeros((nc ** D, 9, 8 * ((n + 7) // 8)), np.float32)
    XB[:, 0, :] = 1e10
    _mirror_all(P, I, XB, XC, n, P[0, PT], L)
    edges = np.arange(nc + 1) * (L / nc)
    edges[-1] = L
    tx, _ = _crossing(P, I, edges, 0, nc, n, L, 0.0, D, False, False, True, False, True)
    lo0, hi0, lo1, hi1, lo2, hi2 = _path_block(P, I, XC, edges, 0, P[0, PT], tx, D)
    lo = (lo0, lo1, lo2)
    hi = (hi0, hi1, hi2)
    covered = np.ones(n, np.bool_)
    for m in range(n):
        for d in range(D):
            o = I[m, C0 + d] - I[0, C0 + d]
            covered[m] = covered[m] and lo[d] <= o <= hi[d]
    return tx, covered


def _touching_partners(rng, p0, tx, k, w, L, rmax, dim):
    """Rows of up to k partners of p0 set up to touch it at a time tc before tx (now for a
    fifth; at contact, or overlapping by 1e-9 of it) and to stay in their own cell from p0's
    time stamp to tc: half of the largest radius, half of the contact normals along an axis
    or the diagonal of two (across a face or an edge at exactly the reach)."""
    tc = p0[PT] + (tx - p0[PT]) * rng.uniform(0.0, 1.0, k) ** 0.3  # (many late: by the exit)
    tc[rng.uniform(size=k) < 0.2] = p0[PT]  # (a fifth touching now)
    r = np.where(rng.uniform(size=k) < 0.5, rmax, rng.uniform(0.05, rmax, k))
    u = rng.normal(size=(k, dim))
    kind = rng.uniform(size=k)
    axis = rng.integers(dim, size=k)
    u[kind < 0.5] = 0.0
    u[kind < 0.5, axis[kind < 0.5]] = rng.choice([-1.0, 1.0], size=int((kind < 0.5).sum()))
    edge = kind < 0.2
    u[edge, ((axis + 1) % dim)[edge]] = rng.choice([-1.0, 1.0], size=int(edge.sum()))
    u /= np.linalg.norm(u, axis=1)[:, None]
    contact = (p0[PR] + r) * np.where(rng.uniform(size=k) < 0.2, 1.0 - 1e-9, 1.0)
    at_tc = p0[:dim] + p0[PV:PV + dim] * (tc - p0[PT])[:, None] + contact[:, None] * u
    v = rng.normal(size=(k, dim))
    now = at_tc - v * (tc - p0[PT])[:, None]
    same = np.all((np.floor(now / w) == np.floor(at_tc / w)) & (now > 0) & (now < L), axis=1)
    q = np.zeros((int(same.sum()), 8))
    q[:, :dim], q[:, PV:PV + dim], q[:, PR], q[:, PT] = now[same], v[same], r[same], p0[PT]
    return q


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("start", ["inside", "near a face, within the reach",
                                   "near an edge, within the reach", "on a face"])
def test_every_partner_that_touches_before_the_exit_is_in_a_scanned_cell(dim, start):
    """Particle 0 in the centre cell of 3 an axis (anywhere; or just inside the reach of a
    face, or of an edge, 1e-9 to 0.1 of it; or on a face, as right after a crossing),
    partners set up to touch it before it leaves its cell and to stay in their own cell
    until then (so that no crossing of their own rescans them): every such partner is in a
    cell its scan covers (the invariant of wide cells: the later of the two particles'
    last events scans the other). Cells a diameter and a bit wide, so that touching across
    faces, edges and corners is common; 200 paths."""
    rng = np.random.default_rng(100 + dim)
    nc, L, rmax = 3, 3.0, 0.45
    w = L / nc
    across = 0
    for _ in range(200):
        p0 = np.zeros(8)
        p0[:dim] = rng.uniform(w, 2 * w, dim)
        p0[PV:PV + dim] = rng.normal(size=dim)
        p0[PT] = 0.7
        p0[PR] = rng.uniform(0.2, rmax)
        a, up = rng.integers(dim), rng.uniform() < 0.5
        b, up_b = (a + 1) % dim, rng.uniform() < 0.5
        depth = (p0[PR] + rmax) * (1.0 - 10.0 ** rng.uniform(-9, -1))
        if start == "on a face":
            p0[a] = 2 * w if up else w
        elif start == "near a face, within the reach":
            p0[a] = 2 * w - depth if up else w + depth
        elif start != "inside":
            angle = rng.uniform(0.1, 0.5 * np.pi - 0.1)
            da, db = depth * np.cos(angle), depth * np.sin(angle)
            p0[a] = 2 * w - da if up else w + da
            p0[b] = 2 * w - db if up_b else w + db
        tx, _ = _covered(p0[None, :].copy(), np.zeros(XC_SIZE), nc, L, dim)
        P = np.vstack([p0[None, :], _touching_partners(rng, p0, tx, 3000, w, L, rmax, dim)])
        tx2, covered = _covered(P, np.zeros(XC_SIZE), nc, L, dim)
        assert tx2 == tx
        missed = np.flatnonzero(~covered[1:])
        assert missed.size == 0, (P[0], P[1 + missed[:3]])
        cells = np.floor(P[1:, :dim] / w) - np.floor(P[0, :dim] / w)
        across += np.count_nonzero(np.abs(cells).sum(axis=1) >= 2)
    assert across > 1000  # (partners across edges and corners were tried)
